"""The particles' floors checked against the INS's own height.

A particle's height [m, the building's z] is its floor's level plus the climb it has
accumulated on a stair. The INS's height, shifted by the offset it had from the start
floor's level, is an independent account of the same quantity: a foot INS's vertical
channel (ZUPT-aided) drifts by a few decimetres over a search, far less than a storey. On
a building whose storeys look alike the search patterns match on every floor and replace
particles on the wrong one, and a cloud that loses its place can hand its weight to them
while the INS has not climbed at all.

* :func:`particle_heights`: each particle's height;
* :class:`HeightCheck`: per firefighter, the offset of the INS's height at the start and
  the log-likelihood ``log(factor)`` of each particle whose height is more than
  ``tolerance`` off the INS's (0 for the others), and whether the published height
  disagrees with the INS's (then the pose's floor is in doubt and it is not trusted).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from firenav_framework.capabilities.particles import Particles

__all__ = ["particle_heights", "HeightCheck"]


def particle_heights(p: Particles, levels: np.ndarray) -> np.ndarray:
    """(N,) height [m] of each particle: its floor's level in ``levels`` (per floor index)
    plus its climb."""
    return levels[p.floor] + p.climb


@dataclass
class HeightCheck:
    """The cloud's heights against the INS's height [m] for one firefighter."""

    tolerance: float
    """a particle more than this [m] above or below the INS's height is on another floor"""
    factor: float
    """weight factor of such a particle at each update (0 < factor <= 1)"""
    offset: float = 0.0
    """the start's height minus the INS's height there [m]"""

    def start(self, height: float, ins_z: float) -> None:
        """Record the offset from the start's ``height`` and the INS's ``ins_z`` there [m]."""
        self.offset = height - ins_z

    def log_likelihood(self, heights: np.ndarray, ins_z: float) -> np.ndarray:
        """(N,) log-weights: ``log(factor)`` where a particle's height is off the INS's."""
        off = np.abs(heights - (ins_z + self.offset)) > self.tolerance
        return np.where(off, math.log(self.factor), 0.0)

    def disagrees(self, height: float, ins_z: float) -> bool:
        """Whether the published ``height`` [m] is more than ``tolerance`` off the INS's."""
        return abs(height - (ins_z + self.offset)) > self.tolerance
