"""Floor changes of particles on stairs.

A particle standing on a stair's footprint accumulates the odometry's vertical
travel in ``climb``; once it has climbed (descended) more than half the stair's rise
it moves to the stair's upper (lower) floor and keeps the remainder. A particle off
every stair has ``climb`` reset to 0: vertical odometry drift elsewhere never moves
a particle between floors, and a floor change always happens where a stair is.
"""
from __future__ import annotations

import numpy as np
import shapely

from firenav_framework.capabilities.particles import Particles

__all__ = ["apply_stairs"]


def apply_stairs(p: Particles, dz: float, building) -> int:
    """Update ``p.floor``/``p.climb`` in place for vertical travel ``dz`` [m]; returns changes."""
    stairs = [s for f in building.floors for s in f.stairs]
    if not stairs:
        return 0
    on_stair = np.zeros(len(p), dtype=bool)
    changed = 0
    climb = p.climb + dz
    for s in stairs:
        inside = shapely.contains_xy(s.polygon, p.xy[:, 0], p.xy[:, 1])
        half = abs(s.rise) / 2
        lower = inside & (p.floor == s.floor_from)
        upper = inside & (p.floor == s.floor_to)
        on_stair |= lower | upper
        up = lower & (climb > half)
        down = upper & (climb < -half)
        p.floor[up] = s.floor_to
        climb[up] -= abs(s.rise)
        p.floor[down] = s.floor_from
        climb[down] += abs(s.rise)
        changed += int(up.sum() + down.sum())
    p.climb = np.where(on_stair, climb, 0.0)
    return changed
