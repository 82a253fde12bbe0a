"""The ``wall_crossing`` constraint: particles may not walk through walls (§IV-E).

"Map information is incorporated by eliminating any particle whose position estimate
crosses a wall" (search-pattern paper §IV-E). With ``mode: remove`` (the paper) a
particle whose move from its previous to its new position touches a wall of its
floor gets weight 0 and is replaced by a copy of a surviving particle. With
``mode: downweight`` its weight is multiplied by ``factor`` instead — gentler when
the plan may be wrong (a door that is really somewhere else, §V-E).

A particle that ends up outside the building's outline has left the map through an
entrance, where no wall constrains it any more; such particles would drift freely
and, as the constrained ones keep being removed, take over the cloud. With
``outside: remove`` (default) leaving the outline counts as crossing a wall.

The moves of all particles are tested in one vectorised call per floor
(``Floor.crosses_wall``, the building model's compiled segment index).
"""
from __future__ import annotations

import math
from typing import Literal

import numpy as np

from firenav_framework import Params, param
from firenav_framework.capabilities.particles import ParticleConstraint, ParticleStep

__all__ = ["WallCrossingConstraint", "crossing_moves"]


def crossing_moves(building, floor: np.ndarray, p0: np.ndarray, p1: np.ndarray,
                   outside_counts: bool = False) -> np.ndarray:
    """bool (N,): does move p0[i] -> p1[i] (N, 2) [m] cross a wall of floor ``floor[i]``
    (or, with ``outside_counts``, end outside that floor's outline)?"""
    out = np.zeros(len(p0), dtype=bool)
    for fl in np.unique(floor):
        sel = np.flatnonzero(floor == fl)
        f = building.floors[int(fl)]
        hit = f.crosses_wall(p0[sel], p1[sel])
        if outside_counts:
            hit |= ~f.inside(p1[sel])
        out[sel] = hit
    return out


class WallCrossingParams(Params):
    mode: Literal["remove", "downweight"] = param(
        "remove", description="remove crossing particles (§IV-E) or multiply their weight by factor")
    factor: float = param(0.01, gt=0, lt=1, description="mode=downweight: weight factor per crossing move")
    outside: Literal["remove", "allow"] = param(
        "remove", description="particles that leave the building outline count as crossing "
        "(remove) or are left alone (allow)")


class WallCrossingConstraint(ParticleConstraint):
    """Particles whose move crosses a wall are removed (or down-weighted)."""

    name = "wall_crossing"
    needs_building = True
    Params = WallCrossingParams

    def log_likelihood(self, step: ParticleStep) -> np.ndarray:
        crossed = crossing_moves(step.building, step.before.floor, step.before.xy,
                                 step.particles.xy, self.params.outside == "remove")
        self.ctx.count("wall_crossings", int(crossed.sum()))
        penalty = -math.inf if self.params.mode == "remove" else math.log(self.params.factor)
        return np.where(crossed, penalty, 0.0)

