"""Batched 2D iterative closest point (ICP) against polyline search patterns.

Algorithm 1 of the search-pattern paper (§IV-D, step 6) runs one ICP per (search
pattern, initial rotation) pair. Here all pairs are solved in one compiled call:
the odometry trajectory ``src`` (P, 2) is matched against ``C`` candidates, each a
pattern polyline (``patterns[pattern_of[c]]``, (L, 2)) and an initial rotation
``init_angle[c]``.

Each iteration pairs every (transformed) odometry point with its closest point on
the pattern polyline (point-to-segment, so the fit does not depend on where the
grid nodes happen to lie along a straight wall) and then solves the least-squares
rigid transform in closed form (2D Kabsch / Umeyama without scale):

    theta = atan2(sum(x~ cross q~), sum(x~ . q~)),   t = q_bar - R(theta) x_bar

with x~, q~ the centred point sets. Iteration stops when the transform moves by
less than ``tol`` (radians / metres) or after ``max_iter`` iterations. The reported
RMSE is that of the final transform against its own closest points.

The transform maps odometry points to the map: ``x_map = R(theta) x + t``.
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

__all__ = ["icp_batch", "closest_on_polylines"]


@njit(cache=True, inline="always")
def _closest_on_polyline(px: float, py: float, pat: np.ndarray) -> tuple[float, float, float]:
    """Closest point (qx, qy) on polyline ``pat`` (L, 2) to (px, py), and its squared distance."""
    best = np.inf
    bx = pat[0, 0]
    by = pat[0, 1]
    for j in range(pat.shape[0] - 1):
        ax = pat[j, 0]
        ay = pat[j, 1]
        dx = pat[j + 1, 0] - ax
        dy = pat[j + 1, 1] - ay
        den = dx * dx + dy * dy
        u = 0.0
        if den > 0.0:
            u = ((px - ax) * dx + (py - ay) * dy) / den
            if u < 0.0:
                u = 0.0
            elif u > 1.0:
                u = 1.0
        qx = ax + u * dx
        qy = ay + u * dy
        d2 = (px - qx) * (px - qx) + (py - qy) * (py - qy)
        if d2 < best:
            best = d2
            bx = qx
            by = qy
    return bx, by, best


@njit(cache=True)
def _icp_one(src: np.ndarray, sx: float, sy: float, pat: np.ndarray, theta: float,
             max_iter: int, tol: float) -> tuple[float, float, float, float, int]:
    """ICP of centred-mean (sx, sy) points ``src`` against one polyline from ``theta``."""
    p = src.shape[0]
    # start: rotate by theta, put the odometry centroid on the pattern's vertex centroid
    cx = 0.0
    cy = 0.0
    for j in range(pat.shape[0]):
        cx += pat[j, 0]
        cy += pat[j, 1]
    cx /= pat.shape[0]
    cy /= pat.shape[0]
    c = np.cos(theta)
    s = np.sin(theta)
    tx = cx - (c * sx - s * sy)
    ty = cy - (s * sx + c * sy)
    iters = 0
    for it in range(max_iter):
        iters = it + 1
        qsx = 0.0
        qsy = 0.0
        a = 0.0
        b = 0.0
        for i in range(p):
            x = src[i, 0]
            y = src[i, 1]
            qx, qy, _ = _closest_on_polyline(c * x - s * y + tx, s * x + c * y + ty, pat)
            qsx += qx
            qsy += qy
            xc = x - sx
            yc = y - sy
            a += xc * qx + yc * qy
            b += xc * qy - yc * qx
        qbx = qsx / p
        qby = qsy / p
        new_theta = np.arctan2(b, a)
        c = np.cos(new_theta)
        s = np.sin(new_theta)
        ntx = qbx - (c * sx - s * sy)
        nty = qby - (s * sx + c * sy)
        dth = abs(np.arctan2(np.sin(new_theta - theta), np.cos(new_theta - theta)))
        moved = max(dth, abs(ntx - tx), abs(nty - ty))
        theta = new_theta
        tx = ntx
        ty = nty
        if moved < tol:
            break
    sse = 0.0
    for i in range(p):
        x = src[i, 0]
        y = src[i, 1]
        _, _, d2 = _closest_on_polyline(c * x - s * y + tx, s * x + c * y + ty, pat)
        sse += d2
    return np.sqrt(sse / p), theta, tx, ty, iters


@njit(cache=True, parallel=True)
def _icp_batch(src: np.ndarray, patterns: np.ndarray, pattern_of: np.ndarray,
               init_angle: np.ndarray, max_iter: int, tol: float,
               rmse: np.ndarray, theta: np.ndarray, trans: np.ndarray,
               iters: np.ndarray) -> None:
    p = src.shape[0]
    sx = 0.0
    sy = 0.0
    for i in range(p):
        sx += src[i, 0]
        sy += src[i, 1]
    sx /= p
    sy /= p
    for k in prange(pattern_of.shape[0]):
        r, th, tx, ty, n = _icp_one(src, sx, sy, patterns[pattern_of[k]], init_angle[k],
                                    max_iter, tol)
        rmse[k] = r
        theta[k] = th
        trans[k, 0] = tx
        trans[k, 1] = ty
        iters[k] = n


def icp_batch(src: np.ndarray, patterns: np.ndarray, pattern_of: np.ndarray,
              init_angle: np.ndarray, *, max_iter: int = 30, tol: float = 1e-4
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Run ICP for every candidate ``c``: ``src`` (P, 2) onto ``patterns[pattern_of[c]]``.

    ``patterns`` (K, L, 2) are polylines in the map frame [m]; ``pattern_of`` (C,)
    picks the pattern of each candidate and ``init_angle`` (C,) its initial rotation
    [rad]. Returns ``rmse`` (C,) [m], ``theta`` (C,) [rad], ``t`` (C, 2) [m] with
    ``x_map = R(theta) x + t``, and the iteration count of each candidate (C,).
    """
    src = np.ascontiguousarray(src, dtype=np.float64)
    patterns = np.ascontiguousarray(patterns, dtype=np.float64)
    pattern_of = np.ascontiguousarray(pattern_of, dtype=np.int64)
    init_angle = np.ascontiguousarray(init_angle, dtype=np.float64)
    if src.ndim != 2 or src.shape[1] != 2 or len(src) < 2:
        raise ValueError(f"ICP source must be (P >= 2, 2) points, got {src.shape}")
    if patterns.ndim != 3 or patterns.shape[2] != 2 or patterns.shape[1] < 2:
        raise ValueError(f"ICP patterns must be (K, L >= 2, 2) polylines, got {patterns.shape}")
    if pattern_of.shape != init_angle.shape:
        raise ValueError("pattern_of and init_angle must have the same length")
    if len(pattern_of) and (pattern_of.min() < 0 or pattern_of.max() >= len(patterns)):
        raise ValueError("pattern_of refers to a pattern that does not exist")
    n = len(pattern_of)
    rmse = np.empty(n)
    theta = np.empty(n)
    trans = np.empty((n, 2))
    iters = np.empty(n, dtype=np.int64)
    if n:
        _icp_batch(src, patterns, pattern_of, init_angle, int(max_iter), float(tol),
                   rmse, theta, trans, iters)
    return rmse, theta, trans, iters


@njit(cache=True)
def _closest_many(points: np.ndarray, pat: np.ndarray, out: np.ndarray) -> None:
    for i in range(points.shape[0]):
        qx, qy, d2 = _closest_on_polyline(points[i, 0], points[i, 1], pat)
        out[i, 0] = qx
        out[i, 1] = qy
        out[i, 2] = d2


def closest_on_polylines(points: np.ndarray, polyline: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Closest points on ``polyline`` (L, 2) to ``points`` (P, 2) and their distances [m]."""
    out = np.empty((len(points), 3))
    _closest_many(np.ascontiguousarray(points, dtype=np.float64),
                  np.ascontiguousarray(polyline, dtype=np.float64), out)
    return out[:, :2], np.sqrt(out[:, 2])
