"""The ``wall_crossing`` constraint: particles may not walk through walls (§IV-E).

"Map information is incorporated by eliminating any particle whose position estimate
crosses a wall" (search-pattern paper §IV-E). With ``mode: remove`` (the paper) a
particle whose move from its previous to its new position touches a wall of its
floor gets weight 0 and is replaced by a copy of a surviving particle. With
``mode: downweight`` its weight is multiplied by ``factor`` instead — gentler when
the plan may be wrong (a door that is really somewhere else, §V-E).

A particle that ends up outside the building's outline has left the map through an
entrance (or, with ``mode: downweight``, through a wall), where no wall constrains it
any more; such particles would drift freely and, as the constrained ones keep being
removed or down-weighted, take over the cloud. With ``outside: remove`` (default) a
particle outside the outline is removed in either mode.

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


def crossing_moves(building, floor: np.ndarray, p0: np.ndarray, p1: np.ndarray) -> np.ndarray:
    """bool (N,): does move p0[i] -> p1[i] (N, 2) [m] cross a wall of floor ``floor[i]``?"""
    out = np.zeros(len(p0), dtype=bool)
    for fl in np.unique(floor):
        sel = np.flatnonzero(floor == fl)
        out[sel] = building.floors[int(fl)].crosses_wall(p0[sel], p1[sel])
    return out


class WallCrossingParams(Params):
    mode: Literal["remove", "downweight"] = param("remove")
    """remove crossing particles (§IV-E) or multiply their weight by factor"""
    factor: float = param(0.01, gt=0, lt=1)
    """mode=downweight: weight factor per crossing move"""
    outside: Literal["remove", "allow"] = param("remove")
    """particles outside the building outline are removed (remove) or left alone (allow)"""


class WallCrossingConstraint(ParticleConstraint):
    """Particles whose move crosses a wall are removed (or down-weighted)."""

    name = "wall_crossing"
    needs_building = True
    Params = WallCrossingParams

    def log_likelihood(self, step: ParticleStep) -> np.ndarray:
        p = step.particles
        crossed = crossing_moves(step.building, step.before.floor, step.before.xy, p.xy)
        self.ctx.count("wall_crossings", int(crossed.sum()))
        penalty = -math.inf if self.params.mode == "remove" else math.log(self.params.factor)
        ll = np.where(crossed, penalty, 0.0)
        if self.params.outside == "remove":
            gone = ~_inside(step.building, p.floor, p.xy)
            self.ctx.count("left_outline", int(gone.sum()))
            ll[gone] = -math.inf
        return ll


def _inside(building, floor: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """bool (N,): is xy[i] (N, 2) [m] inside the outline of floor ``floor[i]``?"""
    out = np.zeros(len(xy), dtype=bool)
    for fl in np.unique(floor):
        sel = np.flatnonzero(floor == fl)
        out[sel] = building.floors[int(fl)].inside(xy[sel])
    return out

