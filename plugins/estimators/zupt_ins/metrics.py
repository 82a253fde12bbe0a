"""Accuracy metrics of the two real foot-IMU datasets, defined as their authors do.

* :func:`pyshoe_armse`: the 2D ARMSE of the PyShoe VICON benchmark (Wagstaff et al.,
  IEEE Sensors J. 2020; utiasSTARS/pyshoe ``align_plots`` + ``compute_error``): both
  trajectories start at the origin, the estimate is rotated about z so that its
  position at the first sample 0.8 m (horizontally) from the start points the same way
  as the ground truth at that sample, and the error is the mean over samples of the
  per-sample RMS over the x and y axes, ``sqrt((dx^2 + dy^2) / 2)`` — note the /2:
  it is the horizontal distance divided by sqrt(2).
* :func:`stride_errors`: the indoor walks, where the truth is one surveyed footprint per
  stride. The unknown INS heading and origin are removed by a 2D rigid fit (rotation +
  translation, least squares) on the first ``n_align`` strides only (what a live system
  could do), then the horizontal error is taken at every stride.
* :func:`shape_error_per_distance`: how far a track's shape departs from the truth per
  metre travelled (lost or added distance, heading drift, false steps), used to compare
  gaits on the short VICON trials: the mean horizontal error after the least-squares 2D
  rigid fit of the whole track, divided by the truth's path length. PyShoe's ARMSE
  aligns the heading on the first 0.8 m, an error that does not grow with distance and
  so weighs most on the shortest trials (the crawls).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

PYSHOE_ALIGN_DISTANCE = 0.8   # [m] PyShoe align_plots(dist=0.8)
PYSHOE_FALLBACK_INDEX = 300   # sample used when the trajectory never gets 0.8 m away


def pyshoe_armse(est: np.ndarray, truth: np.ndarray) -> float:
    """2D ARMSE [m] of ``est`` (N, >=2) against ``truth`` (N, >=2), sample by sample."""
    est = np.asarray(est, float)[:, :2]
    truth = np.asarray(truth, float)[:, :2]
    if est.shape != truth.shape or len(est) < 2:
        raise ValueError(f"need two equally long trajectories, got {est.shape} and {truth.shape}")
    a = est - est[0]
    b = truth - truth[0]
    d = np.hypot(a[1:, 0], a[1:, 1])      # PyShoe: cumulative sum of differences = a[i+1]
    ind = int(np.argmax(d >= PYSHOE_ALIGN_DISTANCE)) if d.max() >= PYSHOE_ALIGN_DISTANCE \
        else min(PYSHOE_FALLBACK_INDEX, len(a) - 1)
    # PyShoe indexes the trajectories (not d) with this index, one sample early; kept.
    u, v = a[ind], b[ind]
    angle = np.arctan2(u[0] * v[1] - u[1] * v[0], u @ v) if np.any(u) and np.any(v) else 0.0
    c, s = np.cos(angle), np.sin(angle)
    rot = a @ np.array([[c, s], [-s, c]])
    return float(np.mean(np.sqrt(np.mean((rot - b) ** 2, axis=1))))


@dataclass(frozen=True)
class StrideErrors:
    """Horizontal errors at the surveyed strides of one walk, after the alignment fit."""

    errors: np.ndarray      # (K,) [m]
    aligned: np.ndarray     # (K, 2) the estimate at the strides, in the survey frame
    distance: float         # [m] surveyed path length (sum of stride-to-stride distances)

    @property
    def mean(self) -> float:
        return float(self.errors.mean())

    @property
    def final(self) -> float:
        return float(self.errors[-1])

    @property
    def mean_percent(self) -> float:
        """Mean error as a percentage of the distance travelled."""
        return 100.0 * self.mean / self.distance


def rigid_fit_2d(src: np.ndarray, dst: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotation R (2, 2) and translation t (2,) minimising sum |R src + t - dst|^2."""
    ms, md = src.mean(axis=0), dst.mean(axis=0)
    h = (src - ms).T @ (dst - md)
    angle = np.arctan2(h[0, 1] - h[1, 0], h[0, 0] + h[1, 1])
    c, s = np.cos(angle), np.sin(angle)
    rot = np.array([[c, -s], [s, c]])
    return rot, md - rot @ ms


def stride_errors(est_at_strides: np.ndarray, truth: np.ndarray, n_align: int = 5,
                  distance: float | None = None) -> StrideErrors:
    """Errors of the estimate at the strides (K, >=2) against the surveyed points (K, 2).

    The rigid fit uses the first ``n_align`` strides (at least 2, and they must not be
    all at one point). ``distance`` defaults to the surveyed path length.
    """
    est = np.asarray(est_at_strides, float)[:, :2]
    truth = np.asarray(truth, float)[:, :2]
    if est.shape != truth.shape:
        raise ValueError(f"estimate {est.shape} and truth {truth.shape} differ in shape")
    n = max(2, min(n_align, len(est)))
    rot, trans = rigid_fit_2d(est[:n], truth[:n])
    aligned = est @ rot.T + trans
    err = np.hypot(*(aligned - truth).T)
    if distance is None:
        distance = float(np.sum(np.hypot(*np.diff(truth, axis=0).T)))
    return StrideErrors(errors=err, aligned=aligned, distance=float(distance))


def path_length(xy: np.ndarray) -> float:
    """Horizontal length [m] of a polyline (N, >=2)."""
    xy = np.asarray(xy, float)[:, :2]
    return float(np.sum(np.hypot(*np.diff(xy, axis=0).T))) if len(xy) > 1 else 0.0


def shape_error_per_distance(est: np.ndarray, truth: np.ndarray, every: int = 10) -> float:
    """Mean horizontal error after a whole-track 2D rigid fit, per metre of truth path.

    ``est`` and ``truth`` (N, >=2) sample the same instants; the path is measured on
    every ``every``-th truth sample (20 Hz for the 200 Hz VICON truth, so that marker
    jitter does not add length).
    """
    est = np.asarray(est, float)[:, :2]
    truth = np.asarray(truth, float)[:, :2]
    if est.shape != truth.shape or len(est) < 2:
        raise ValueError(f"need two equally long trajectories, got {est.shape} and {truth.shape}")
    rot, trans = rigid_fit_2d(est, truth)
    err = np.hypot(*(est @ rot.T + trans - truth).T)
    return float(err.mean()) / max(path_length(truth[::every]), 1e-9)
