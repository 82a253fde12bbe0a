"""Uniform-grid index over 2-D line segments and the vectorised queries built on it.

The particle filter asks "which of these N moves cross a wall?" thousands of times per
second, so the index is built once per floor and every query is one compiled (numba)
pass over the moves: each move visits only the grid cells its own segment touches and
tests only the walls registered in those cells.

Geometry conventions (shared by the grid kernels and the brute-force reference
:func:`segments_hit_bruteforce`, so both give identical answers):

* Segments are **closed**: touching counts. A move that ends (or starts) exactly on a
  wall, or slides along it, hits it. Points closer than ``EPS`` (1e-9 m) to a segment's
  line count as on it, so exactly-representable hand-computed cases behave as drawn.
* Coordinates are metres in the floor's ENU frame; arrays are float64.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["SegmentIndex", "segments_hit_bruteforce", "segments_hit_walk", "segments_near_sorted",
           "EPS", "FIRST", "ANY", "ALL", "COUNT"]

#: Distance [m] below which a point counts as lying on a segment's line.
EPS = 1e-9
#: Most (cell, segment) entries a grid holds (160 MB of int64); beyond, cells grow.
MAX_GRID_ITEMS = 20_000_000


# --------------------------------------------------------------------------- predicates

@njit(cache=True, inline="always")
def _side(ax, ay, bx, by, px, py, length):
    """Sign (-1, 0, +1) of point p relative to the line a->b; 0 within EPS metres."""
    o = (bx - ax) * (py - ay) - (by - ay) * (px - ax)
    if abs(o) <= EPS * length:
        return 0
    return 1 if o > 0.0 else -1


@njit(cache=True)
def _hit_frac(p0x, p0y, p1x, p1y, w0x, w0y, w1x, w1y):
    """Fraction along the move p0->p1 where it first touches wall w0-w1, or -1.0 (no hit)."""
    dx = p1x - p0x
    dy = p1y - p0y
    ex = w1x - w0x
    ey = w1y - w0y
    lm = math.sqrt(dx * dx + dy * dy)
    lw = math.sqrt(ex * ex + ey * ey)
    s1 = _side(w0x, w0y, w1x, w1y, p0x, p0y, lw)
    s2 = _side(w0x, w0y, w1x, w1y, p1x, p1y, lw)
    if s1 * s2 > 0:
        return -1.0
    if s1 == 0 and s2 == 0:
        # Both move ends on the wall's line: overlap of the projections on the wall.
        if lw == 0.0:
            return -1.0
        ux = ex / lw
        uy = ey / lw
        a = (p0x - w0x) * ux + (p0y - w0y) * uy
        b = (p1x - w0x) * ux + (p1y - w0y) * uy
        if max(a, b) < -EPS or min(a, b) > lw + EPS:
            return -1.0
        if a >= -EPS and a <= lw + EPS:
            return 0.0
        # Enters the wall at its nearer end.
        entry = 0.0 if a < 0.0 else lw
        return min(1.0, max(0.0, (entry - a) / (b - a)))
    s3 = _side(p0x, p0y, p1x, p1y, w0x, w0y, lm)
    s4 = _side(p0x, p0y, p1x, p1y, w1x, w1y, lm)
    if s3 * s4 > 0:
        return -1.0
    den = dx * ey - dy * ex
    if den == 0.0:
        # Zero-length move lying on the wall's line but inside the wall's extent.
        return 0.0
    t = ((w0x - p0x) * ey - (w0y - p0y) * ex) / den
    return min(1.0, max(0.0, t))


@njit(cache=True)
def _point_seg_dist2(px, py, ax, ay, bx, by):
    """Squared distance from p to segment a-b and the parameter of the closest point."""
    ex = bx - ax
    ey = by - ay
    l2 = ex * ex + ey * ey
    u = 0.0
    if l2 > 0.0:
        u = ((px - ax) * ex + (py - ay) * ey) / l2
        u = min(1.0, max(0.0, u))
    cx = ax + u * ex - px
    cy = ay + u * ey - py
    return cx * cx + cy * cy, u


# --------------------------------------------------------------------------- grid walking

@njit(cache=True)
def _row_span(x0, y0, x1, y1, j, ox, oy, h, nx, pad):
    """Column range [i0, i1] of grid row j touched by segment (x0,y0)-(x1,y1); i0 > i1 if none."""
    ylo = oy + j * h - pad
    yhi = oy + (j + 1) * h + pad
    dy = y1 - y0
    if dy == 0.0:
        if y0 < ylo or y0 > yhi:
            return 0, -1
        t0 = 0.0
        t1 = 1.0
    else:
        ta = (ylo - y0) / dy
        tb = (yhi - y0) / dy
        t0 = max(0.0, min(ta, tb))
        t1 = min(1.0, max(ta, tb))
        if t0 > t1:
            return 0, -1
    xa = x0 + t0 * (x1 - x0)
    xb = x0 + t1 * (x1 - x0)
    i0 = int(math.floor((min(xa, xb) - pad - ox) / h))
    i1 = int(math.floor((max(xa, xb) + pad - ox) / h))
    return max(i0, 0), min(i1, nx - 1)


@njit(cache=True)
def _row_range(y0, y1, oy, h, ny, pad):
    j0 = int(math.floor((min(y0, y1) - pad - oy) / h))
    j1 = int(math.floor((max(y0, y1) + pad - oy) / h))
    return max(j0, 0), min(j1, ny - 1)


@njit(cache=True)
def _visit_cells(segs, ox, oy, h, nx, ny, pad, per_cell, items):
    """Walk every (segment w, cell c) pair that touches. Counting (``items`` empty):
    ``per_cell[c + 1] += 1``. Filling: ``items[per_cell[c]] = w; per_cell[c] += 1``."""
    filling = items.shape[0] > 0
    for w in range(segs.shape[0]):
        x0, y0, x1, y1 = segs[w, 0, 0], segs[w, 0, 1], segs[w, 1, 0], segs[w, 1, 1]
        j0, j1 = _row_range(y0, y1, oy, h, ny, pad)
        for j in range(j0, j1 + 1):
            i0, i1 = _row_span(x0, y0, x1, y1, j, ox, oy, h, nx, pad)
            for i in range(i0, i1 + 1):
                c = j * nx + i
                if filling:
                    items[per_cell[c]] = w
                    per_cell[c] += 1
                else:
                    per_cell[c + 1] += 1


#: What :func:`segments_hit_walk` looks for per move.
FIRST, ANY, ALL, COUNT = 0, 1, 2, 3


@njit(cache=True)
def segments_hit_walk(p0, p1, segs, start, items, ox, oy, h, nx, ny, pad, mode, out_m, out_w,
                      limit):
    """The compiled walk behind :meth:`SegmentIndex.crosses`, ``first_hit``, ``all_hits``
    and ``count_hits``, for compiled or hot-path callers that check their own moves.

    Walks each move p0[m] -> p1[m] ((N, 2) float64 C-contiguous, finite, [m], floor ENU)
    over its cells and tests the segments registered there, each once. The grid is the
    index's own: ``segs, start, items, ox, oy, h, nx, ny`` = :meth:`SegmentIndex.grid_args`
    and ``pad`` = :attr:`SegmentIndex.pad`. ``out_m`` / ``out_w`` are int64 (empty unless
    ``mode`` is ``ALL``).

    ``FIRST``: per move the fraction of the first hit (ties to the lowest segment index)
    and its segment, else -1 / -1; ``ANY``: the same but stops at the move's first hit
    found (its fraction is of that hit). ``ALL``: every touching (move, segment) pair
    into ``out_m`` / ``out_w``; ``COUNT``: only counted. ALL and COUNT stop once
    ``limit`` pairs are found (negative: no limit). Returns (fraction (N,), segment
    (N,), pairs found)."""
    n = p0.shape[0]
    frac = np.full(n, -1.0)
    which = np.full(n, -1, dtype=np.int64)
    stamp = np.full(segs.shape[0], -1, dtype=np.int64)
    pairs = 0
    for m in range(n):
        x0, y0, x1, y1 = p0[m, 0], p0[m, 1], p1[m, 0], p1[m, 1]
        best = 2.0
        bestw = -1
        j0, j1 = _row_range(y0, y1, oy, h, ny, pad)
        for j in range(j0, j1 + 1):
            i0, i1 = _row_span(x0, y0, x1, y1, j, ox, oy, h, nx, pad)
            for i in range(i0, i1 + 1):
                c = j * nx + i
                for k in range(start[c], start[c + 1]):
                    w = items[k]
                    if stamp[w] == m:
                        continue
                    stamp[w] = m
                    t = _hit_frac(x0, y0, x1, y1, segs[w, 0, 0], segs[w, 0, 1],
                                  segs[w, 1, 0], segs[w, 1, 1])
                    if t < 0.0:
                        continue
                    if mode >= ALL:
                        if mode == ALL:
                            out_m[pairs] = m
                            out_w[pairs] = w
                        pairs += 1
                        if pairs == limit:
                            return frac, which, pairs
                    elif t < best or (t == best and w < bestw):
                        best = t
                        bestw = w
            if mode == ANY and bestw >= 0:
                break
        if bestw >= 0:
            frac[m] = best
            which[m] = bestw
    return frac, which, pairs


@njit(cache=True, inline="always")
def _box_cells(px, py, radius, ox, oy, h, nx, ny):
    """Cell ranges (i0, i1, j0, j1) of the square of half-side ``radius`` [m] about
    (px, py), clamped to the grid; empty when i0 > i1 or j0 > j1."""
    i0 = max(int(math.floor((px - radius - ox) / h)), 0)
    i1 = min(int(math.floor((px + radius - ox) / h)), nx - 1)
    j0 = max(int(math.floor((py - radius - oy) / h)), 0)
    j1 = min(int(math.floor((py + radius - oy) / h)), ny - 1)
    return i0, i1, j0, j1


@njit(cache=True, inline="always")
def _gather_cell(px, py, c, segs, start, items, stamp, tag, out, dist2, n):
    """Append the segments of cell ``c`` that query ``tag`` has not seen yet to
    ``out[n:]`` and their squared distances [m^2] from (px, py) to ``dist2[n:]``; marks
    them seen in ``stamp`` and returns the new n (each segment is gathered once a query,
    so W entries always suffice)."""
    for k in range(start[c], start[c + 1]):
        w = items[k]
        if stamp[w] == tag:
            continue
        stamp[w] = tag
        d2, _ = _point_seg_dist2(px, py, segs[w, 0, 0], segs[w, 0, 1],
                                 segs[w, 1, 0], segs[w, 1, 1])
        out[n] = w
        dist2[n] = d2
        n += 1
    return n


@njit(cache=True)
def _nearest(pts, segs, start, items, ox, oy, h, nx, ny):
    """Nearest segment per point by ring search around the point's (clamped) cell."""
    n = pts.shape[0]
    dist = np.empty(n)
    which = np.full(n, -1, dtype=np.int64)
    closest = np.empty((n, 2))
    stamp = np.full(segs.shape[0], -1, dtype=np.int64)
    cand = np.empty(segs.shape[0], dtype=np.int64)
    cand_d2 = np.empty(segs.shape[0])
    rmax = max(nx, ny)
    for m in range(n):
        px, py = pts[m, 0], pts[m, 1]
        ci = min(max(int(math.floor((px - ox) / h)), 0), nx - 1)
        cj = min(max(int(math.floor((py - oy) / h)), 0), ny - 1)
        best = np.inf
        bestw = -1
        for r in range(rmax + 1):
            # Rings 0..r-1 are done; anything in ring >= r is at least (r-1)*h away.
            if bestw >= 0 and math.sqrt(best) <= (r - 1) * h:
                break
            found = 0
            for j in range(cj - r, cj + r + 1):
                if j < 0 or j >= ny:
                    continue
                edge_row = j == cj - r or j == cj + r
                step = 1 if edge_row else 2 * r
                i = ci - r
                while i <= ci + r:
                    if 0 <= i < nx:
                        found = _gather_cell(px, py, j * nx + i, segs, start, items, stamp, m,
                                             cand, cand_d2, found)
                    i += step
            for q in range(found):
                w = cand[q]
                d2 = cand_d2[q]
                if d2 < best or (d2 == best and w < bestw):
                    best = d2
                    bestw = w
        which[m] = bestw
        if bestw >= 0:
            dist[m] = math.sqrt(best)
            _, u = _point_seg_dist2(px, py, segs[bestw, 0, 0], segs[bestw, 0, 1],
                                    segs[bestw, 1, 0], segs[bestw, 1, 1])
            closest[m, 0] = segs[bestw, 0, 0] + u * (segs[bestw, 1, 0] - segs[bestw, 0, 0])
            closest[m, 1] = segs[bestw, 0, 1] + u * (segs[bestw, 1, 1] - segs[bestw, 0, 1])
        else:
            dist[m] = np.inf
            closest[m, 0] = np.nan
            closest[m, 1] = np.nan
    return dist, closest, which


@njit(cache=True)
def _bruteforce(p0, p1, segs):
    n = p0.shape[0]
    frac = np.full(n, -1.0)
    which = np.full(n, -1, dtype=np.int64)
    for m in range(n):
        for w in range(segs.shape[0]):
            t = _hit_frac(p0[m, 0], p0[m, 1], p1[m, 0], p1[m, 1], segs[w, 0, 0],
                          segs[w, 0, 1], segs[w, 1, 0], segs[w, 1, 1])
            if t >= 0.0 and (which[m] < 0 or t < frac[m]):
                frac[m] = t
                which[m] = w
    return frac, which


# --------------------------------------------------------------------------- public API

def _as_points(a: np.ndarray, name: str) -> np.ndarray:
    arr = np.asarray(a, dtype=np.float64)
    if arr.ndim == 1 and arr.shape == (2,):
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise ValueError(f"{name} must have shape (N, 2) [m], got {np.shape(a)}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} contains NaN or infinite coordinates")
    return np.ascontiguousarray(arr)


def _as_moves(p0: np.ndarray, p1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    a = _as_points(p0, "p0")
    b = _as_points(p1, "p1")
    if a.shape != b.shape:
        raise ValueError(f"p0 and p1 must have the same shape, got {a.shape} and {b.shape}")
    return a, b


class SegmentIndex:
    """A uniform grid over a fixed set of segments (W, 2, 2) [m], built once.

    ``cell`` is the grid spacing [m]; by default half the square root of the bounding
    area per segment (clipped to 0.5-4 m): about 1 m for office floors, where a cell
    then holds one or two walls and a particle's step touches one to four cells. Queries outside the grid simply find no segments there.
    """

    def __init__(self, segments: np.ndarray, cell: float | None = None):
        segs = np.asarray(segments, dtype=np.float64).reshape(-1, 2, 2)
        if not np.all(np.isfinite(segs)):
            raise ValueError("segments contain NaN or infinite coordinates")
        self.segments = np.ascontiguousarray(segs)
        if len(segs):
            lo = segs.reshape(-1, 2).min(axis=0)
            hi = segs.reshape(-1, 2).max(axis=0)
        else:
            lo = hi = np.zeros(2)
        span = np.maximum(hi - lo, 1e-6)
        if cell is None:
            cell = float(np.clip(0.5 * math.sqrt(span[0] * span[1] / max(len(segs), 1)), 0.5, 4.0))
        if not (cell > 0 and math.isfinite(cell)):
            raise ValueError(f"grid cell must be a positive size in metres, got {cell}")
        # Cap the grid at about 4 million cells whatever the extent.
        cell = max(cell, math.sqrt(span[0] * span[1] / 4e6))
        #: Padding [m] that makes cell membership conservative for points on cell borders.
        self.pad = 1e-7 * max(1.0, float(np.abs(segs).max()) if len(segs) else 1.0)
        while True:
            self.cell = float(cell)
            self.origin = lo - self.cell  # one empty cell of margin on each side
            self.shape = (int(span[0] // self.cell) + 3, int(span[1] // self.cell) + 3)  # (nx, ny)
            # Long segments criss-crossing the grid (a damaged plan) would register in
            # many cells each: coarser cells keep the lists to MAX_GRID_ITEMS entries.
            counts = np.zeros(self.shape[0] * self.shape[1] + 1, dtype=np.int64)
            _visit_cells(*self._cell_args(), counts, np.empty(0, dtype=np.int64))
            if counts.sum() <= MAX_GRID_ITEMS:
                break
            cell *= 2.0
        # CSR lists of the segments touching each cell: cell c holds
        # items[start[c]:start[c + 1]].
        self._start = np.cumsum(counts)
        self._items = np.empty(self._start[-1], dtype=np.int64)
        _visit_cells(*self._cell_args(), self._start[:-1].copy(), self._items)

    def _cell_args(self):
        return (self.segments, float(self.origin[0]), float(self.origin[1]), self.cell,
                self.shape[0], self.shape[1], self.pad)

    def __len__(self) -> int:
        return len(self.segments)

    @property
    def cells(self) -> tuple[np.ndarray, np.ndarray]:
        """The grid as CSR lists for compiled callers: ``(start, items)``; the segments of
        cell (i, j) are ``items[start[c]:start[c + 1]]`` with ``c = j * nx + i``, cell (i, j)
        covering x in origin[0] + [i, i + 1) * cell (and likewise y)."""
        return self._start, self._items

    def grid_args(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, float, float, float, int,
                                 int]:
        """The grid as the compiled kernels take it: ``(segs, start, items, ox, oy, h, nx,
        ny)`` = (:attr:`segments` (W, 2, 2) [m], :attr:`cells`, ``origin`` [m], ``cell``
        [m], ``shape``), the leading arguments of :func:`segments_near_sorted` and, followed
        by :attr:`pad`, of :func:`segments_hit_walk`."""
        return (self.segments, self._start, self._items, float(self.origin[0]),
                float(self.origin[1]), self.cell, self.shape[0], self.shape[1])

    def crosses(self, p0: np.ndarray, p1: np.ndarray) -> np.ndarray:
        """bool (N,): does move i (p0[i] -> p1[i]) touch any segment?"""
        return self._walk(p0, p1, ANY)[0] >= 0.0

    def first_hit(self, p0: np.ndarray, p1: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(hit (N,), fraction in [0, 1] of the move at the first contact (NaN if none),
        segment index (N,) or -1). Ties in fraction go to the lowest segment index."""
        frac, which, _ = self._walk(p0, p1, FIRST)
        hit = which >= 0
        return hit, np.where(hit, frac, np.nan), which

    def all_hits(self, p0: np.ndarray, p1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Every touching (move index, segment index) pair, sorted by move then segment."""
        n = self._walk(p0, p1, COUNT)[2]
        out_m = np.empty(n, dtype=np.int64)
        out_w = np.empty(n, dtype=np.int64)
        self._walk(p0, p1, ALL, out_m, out_w)
        order = np.lexsort((out_w, out_m))
        return out_m[order], out_w[order]

    def count_hits(self, p0: np.ndarray, p1: np.ndarray, limit: int) -> int:
        """Number of touching (move, segment) pairs, counted up to ``limit`` (> 0) only, so
        the cost is bounded however many there are."""
        return int(self._walk(p0, p1, COUNT, limit=max(1, int(limit)))[2])

    def _walk(self, p0: np.ndarray, p1: np.ndarray, mode: int,
              out_m: np.ndarray | None = None, out_w: np.ndarray | None = None,
              limit: int = -1) -> tuple[np.ndarray, np.ndarray, int]:
        a, b = _as_moves(p0, p1)
        none = np.empty(0, dtype=np.int64)
        return segments_hit_walk(a, b, *self.grid_args(), self.pad, mode,
                                 none if out_m is None else out_m,
                                 none if out_w is None else out_w, limit)

    def nearest(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(distance (N,) [m], closest point (N, 2), segment index (N,)); inf/NaN/-1 if empty."""
        pts = _as_points(points, "points")
        if len(self.segments) == 0:
            n = len(pts)
            return np.full(n, np.inf), np.full((n, 2), np.nan), np.full(n, -1, dtype=np.int64)
        return _nearest(pts, *self.grid_args())

    def near(self, point: np.ndarray, radius: float) -> np.ndarray:
        """Indices (sorted) of the segments within ``radius`` [m] of ``point`` (2,)."""
        p = _as_points(point, "point")[0]
        if not (radius >= 0 and math.isfinite(radius)):
            raise ValueError(f"radius must be a finite distance >= 0 [m], got {radius}")
        nx, ny = self.shape
        i0, i1, j0, j1 = _box_cells(float(p[0]), float(p[1]), float(radius),
                                    float(self.origin[0]), float(self.origin[1]), self.cell,
                                    nx, ny)
        if i0 > i1 or j0 > j1:
            return np.empty(0, dtype=np.int64)
        rows = np.arange(j0, j1 + 1)[:, None] * nx + np.arange(i0, i1 + 1)[None, :]
        cells = rows.ravel()
        cand = np.unique(np.concatenate([self._items[self._start[c]:self._start[c + 1]]
                                         for c in cells]))
        if len(cand) == 0:
            return cand
        d = _segment_distances(p, self.segments[cand])
        return cand[d <= radius]


def _segment_distances(p: np.ndarray, segs: np.ndarray) -> np.ndarray:
    """Distances [m] from one point (2,) to each segment (K, 2, 2)."""
    a = segs[:, 0]
    e = segs[:, 1] - a
    l2 = np.einsum("ij,ij->i", e, e)
    u = np.clip(np.einsum("ij,ij->i", p - a, e) / np.where(l2 > 0, l2, 1.0), 0.0, 1.0)
    return np.linalg.norm(a + u[:, None] * e - p, axis=1)


def segments_hit_bruteforce(p0: np.ndarray, p1: np.ndarray,
                            segments: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Reference answer of :meth:`SegmentIndex.first_hit` testing every move against every
    segment (no grid). For tests and benchmarks; O(N * W)."""
    a, b = _as_moves(p0, p1)
    segs = np.ascontiguousarray(np.asarray(segments, dtype=np.float64).reshape(-1, 2, 2))
    frac, which = _bruteforce(a, b, segs)
    hit = which >= 0
    return hit, np.where(hit, frac, np.nan), which


@njit(cache=True)
def segments_near_sorted(px, py, radius, segs, start, items, ox, oy, h, nx, ny, stamp, tag,
                         out, dist2):
    """:meth:`SegmentIndex.near` for compiled callers that ask once per step, nearest first.

    Writes the indices of the segments within ``radius`` [m] of the point (px, py) to
    ``out[:n]``, sorted by distance (equal distances: lower index first), and their
    squared distances [m^2] to ``dist2[:n]``; returns n. The grid is the index's own:
    ``segs, start, items, ox, oy, h, nx, ny`` = :meth:`SegmentIndex.grid_args`. ``stamp`` (W,) int64 marks the segments already seen by query ``tag``:
    with a new tag per query the buffer never needs clearing. ``out`` and ``dist2`` hold
    W entries. Nothing is allocated.
    """
    i0, i1, j0, j1 = _box_cells(px, py, radius, ox, oy, h, nx, ny)
    total = 0
    for j in range(j0, j1 + 1):
        for i in range(i0, i1 + 1):
            total = _gather_cell(px, py, j * nx + i, segs, start, items, stamp, tag, out,
                                 dist2, total)
    # Keep those within the radius, nearest first, in place: entry q is read before the
    # sorted prefix (n <= q entries) can grow over it. Insertion sort: a step's
    # neighbourhood holds few walls.
    r2 = radius * radius
    n = 0
    for q in range(total):
        w = out[q]
        d2 = dist2[q]
        if d2 <= r2:
            m = n
            while m > 0 and (dist2[m - 1] > d2 or (dist2[m - 1] == d2 and out[m - 1] > w)):
                dist2[m] = dist2[m - 1]
                out[m] = out[m - 1]
                m -= 1
            dist2[m] = d2
            out[m] = w
            n += 1
    return n
