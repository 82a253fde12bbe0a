"""Floor changes of particles on stairs.

A particle on a stair's footprint, or within ``margin`` [m] of it, accumulates the
odometry's vertical travel in ``climb``; once it has climbed (descended) more than half
the stair's rise it moves to the stair's upper (lower) floor and keeps the remainder. A
particle farther than that from every stair has ``climb`` reset to 0: vertical odometry
drift elsewhere never moves a particle between floors, and a floor change always happens
at a stair. The margin lets a particle whose position is off by a step or two (a cloud
spread across a narrow flight, the well of a U-shaped stair, a flight whose top is its
footprint's edge) finish the climb it started.
"""
from __future__ import annotations

import numpy as np
import shapely

from firenav_framework.capabilities.particles import Particles

__all__ = ["StairRegions"]


class StairRegions:
    """The building's stairs as regions where particles may climb between floors."""

    def __init__(self, building, margin: float = 0.0):
        """``margin`` [m]: how far outside a stair's footprint a particle still climbs."""
        self.stairs = [s for f in building.floors for s in f.stairs]
        self.regions = [s.polygon.buffer(margin) if margin > 0 else s.polygon
                        for s in self.stairs]
        for r in self.regions:
            shapely.prepare(r)

    def apply(self, p: Particles, dz: float) -> int:
        """Update ``p.floor``/``p.climb`` in place for vertical travel ``dz`` [m]; returns
        the number of particles that changed floor."""
        if not self.stairs:
            return 0
        on_stair = np.zeros(len(p), dtype=bool)
        changed = 0
        climb = p.climb + dz
        for s, region in zip(self.stairs, self.regions):
            inside = shapely.contains_xy(region, p.xy[:, 0], p.xy[:, 1])
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
