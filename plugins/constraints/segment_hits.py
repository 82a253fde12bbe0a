"""The building index's grid walk for the few moves a constraint asks about per step.

:meth:`SegmentIndex.first_hit` and :meth:`~SegmentIndex.crosses` take any array of
moves and check its shape and that every coordinate is finite before the compiled walk:
right at the building's public interface, but for the few moves a constraint asks
about on every step (four free-space rays, one reset line) those checks cost about ten
times the walk itself.
:class:`SegmentHits` holds one index's grid arrays and calls the same compiled walk
(:func:`firenav_framework.building.index.segments_hit_walk` on the index's
:meth:`~SegmentIndex.grid_args`, so the answers are the index's own)
with the constraint's own positions, which it checks once, as scalars.
"""
from __future__ import annotations

import math

import numpy as np

from firenav_framework.building.index import (ANY, FIRST, SegmentIndex, segments_hit_walk,
                                              segments_near_sorted)

__all__ = ["FloorWalls", "SegmentHits"]

_NONE = np.empty(0, dtype=np.int64)


class SegmentHits:
    """First-hit and any-hit queries of moves (N, 2) -> (N, 2) [m] against one index."""

    def __init__(self, index: SegmentIndex) -> None:
        self.segments = index.segments
        self._grid = index.grid_args()
        self._walk = (*self._grid, index.pad)
        n = max(len(index.segments), 1)     # scratch of the compiled neighbour query
        self._stamp = np.full(n, -1, dtype=np.int64)
        self._tag = 0
        self._near = np.empty(n, dtype=np.int64)
        self._dist2 = np.empty(n)

    def first_hit(self, p0: np.ndarray, p1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(fraction (N,) of each move at its first contact, -1 for none; segment index
        (N,), -1 for none), as :meth:`SegmentIndex.first_hit` (ties to the lowest index)."""
        a, b = _moves(p0, p1)
        frac, which, _ = segments_hit_walk(a, b, *self._walk, FIRST, _NONE, _NONE, -1)
        return frac, which

    def crosses(self, p0: np.ndarray, p1: np.ndarray) -> np.ndarray:
        """bool (N,): does move i touch any segment (:meth:`SegmentIndex.crosses`)?"""
        a, b = _moves(p0, p1)
        return segments_hit_walk(a, b, *self._walk, ANY, _NONE, _NONE, -1)[0] >= 0.0

    def near(self, point: np.ndarray, radius: float) -> np.ndarray:
        """Indices (sorted) of the segments within ``radius`` [m] of ``point`` (2,), as
        :meth:`SegmentIndex.near` (through the compiled
        :func:`~firenav_framework.building.index.segments_near_sorted`)."""
        x, y = float(point[0]), float(point[1])
        if not (math.isfinite(x + y) and radius >= 0 and math.isfinite(radius)):
            raise ValueError(f"near({point}, {radius}): a finite point and radius >= 0 [m]")
        self._tag += 1
        n = segments_near_sorted(x, y, float(radius), *self._grid, self._stamp, self._tag,
                                 self._near, self._dist2)
        return np.sort(self._near[:n])

    def crosses_one(self, p0: np.ndarray, p1: np.ndarray) -> bool:
        """Does the single move ``p0`` -> ``p1`` (2,) [m] touch any segment?"""
        return bool(self.crosses(np.asarray(p0, float)[None, :2],
                                 np.asarray(p1, float)[None, :2])[0])


class FloorWalls:
    """The :class:`SegmentHits` of each floor's walls of a building, built on first use."""

    def __init__(self, building) -> None:
        self._building = building
        self._floors: dict[int, SegmentHits] = {}

    def at_z(self, z: float) -> SegmentHits:
        """The walls of the floor holding height ``z`` [m] (``Building.floor_of_z``)."""
        k = self._building.floor_of_z(z)
        walls = self._floors.get(k)
        if walls is None:
            walls = self._floors[k] = SegmentHits(self._building.floors[k].wall_index)
        return walls


def _moves(p0: np.ndarray, p1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    a = np.ascontiguousarray(p0, dtype=np.float64)
    b = np.ascontiguousarray(p1, dtype=np.float64)
    if a.shape != b.shape or a.ndim != 2 or a.shape[1] != 2:
        raise ValueError(f"moves must be two (N, 2) arrays [m], got {a.shape} and {b.shape}")
    if not math.isfinite(float(a.sum()) + float(b.sum())):
        raise ValueError("a move has a NaN or infinite coordinate")
    return a, b
