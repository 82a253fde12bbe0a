"""Height from counted stairs, the stair rise of the building, and floor levels.

The RFID/MEMS paper ("MEMS Navigation Module") gets the vertical displacement by counting
stairs at a nominal 20 cm each. When the building model knows the stair the agent is on,
its true rise (floor-to-floor height over its number of steps) is used instead
(:meth:`StairMap.rise_at`); the same zones tell the gait classifier where stairs can be. :func:`snap_levels` lists the heights a flight can end on: the
floor levels and the landings of the building's stairs; the estimator sets the height to
the nearest one when a flight ends close to it, which takes out the counting error.
"""
from __future__ import annotations

import numpy as np
import shapely

from firenav_framework.building import Building, Stair

__all__ = ["StairMap", "snap_levels"]


class StairMap:
    """The building's stairs as zones: which stair (if any) a position is on, and its rise.

    A position is on a stair when it lies within ``margin`` [m] of the stair's footprint
    and within a metre of its height range (the estimated height is coarse).
    """

    def __init__(self, building: Building | None, margin: float = 1.0):
        stairs = building.stairs if building is not None else []
        self._stairs = [(s.polygon.buffer(margin), s) for s in stairs]
        for geom, _ in self._stairs:
            shapely.prepare(geom)

    def __len__(self) -> int:
        return len(self._stairs)

    def find(self, position: np.ndarray) -> Stair | None:
        """The stair at ``position`` (3,) [m], or None."""
        x, y, z = (float(v) for v in position[:3])
        for geom, s in self._stairs:
            lo, hi = min(s.z_from, s.z_to), max(s.z_from, s.z_to)
            if lo - 1.0 <= z <= hi + 1.0 and shapely.contains_xy(geom, x, y):
                return s
        return None

    def rise_at(self, position: np.ndarray) -> float | None:
        """Rise of one stair [m] of the stair at ``position``, or None off the stairs."""
        s = self.find(position)
        return None if s is None else abs(s.step_height)


def snap_levels(building: Building) -> np.ndarray:
    """Sorted heights [m] where a flight of stairs can end: every floor level, and the
    landings of the stairs. A landing is the middle of an inner segment of the stair's
    walking line (a U-shaped stair) or its single turn (an L-shaped one), at the height
    the stair model gives there (linear along the line)."""
    levels = [f.z for f in building.floors]
    for s in building.stairs:
        seg = np.linalg.norm(np.diff(s.path, axis=0), axis=1)
        total = float(seg.sum())
        if total <= 0:
            continue
        ends = np.concatenate([[0.0], np.cumsum(seg)]) / total
        if len(s.path) == 3:
            marks = [ends[1]]
        else:
            marks = [(ends[i] + ends[i + 1]) / 2 for i in range(1, len(s.path) - 2)]
        levels += [s.z_from + f * s.rise for f in marks]
    return np.unique(np.round(levels, 6))
