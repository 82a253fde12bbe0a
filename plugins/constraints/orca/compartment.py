"""Which compartment the walker is in, as far as evidence other than the walls says.

The walls around the track (:mod:`.free_space`) say where the walker is *within* a
compartment, never which compartment it is: a wrong corridor's walls hold a track as
tightly as the right one's. That question is answered only by the entry fix, the UWB
ranges and the odometry walked since. :class:`CompartmentDoubt` keeps a horizontal
covariance (2, 2) [m^2] (ENU) of that evidence alone: its largest sigma grows by
``growth`` metres per metre walked (the INS's drift along and across the path), and
every range to an anchor in line of sight narrows it along the line to that anchor (a
scalar Kalman update with the range's sigma; the constraint passes no range through
walls or a slab, whose bias the sigma does not state). It never sees the walls, so
walking a wrong corridor does not shrink it.
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["CompartmentDoubt"]


class CompartmentDoubt:
    """The covariance of the walker's position from the odometry and ranges only."""

    def __init__(self, growth: float) -> None:
        self.growth = growth
        """sigma added per metre walked [m/m]"""
        self.cov = np.zeros((2, 2))
        """horizontal covariance [m^2] beyond the estimator's start uncertainty"""

    def walk(self, length: float) -> None:
        """Widen by a move of ``length`` [m]: the largest sigma grows by growth x length."""
        a, b, d = self.cov[0, 0], self.cov[0, 1], self.cov[1, 1]
        sigma = math.sqrt(max(0.5 * (a + d) + math.hypot(0.5 * (a - d), b), 0.0))
        grow = self.growth * length
        self.cov = self.cov + np.eye(2) * grow * (2.0 * sigma + grow)

    def range_to(self, position: np.ndarray, anchor: np.ndarray, sigma: float) -> None:
        """Narrow by a range of ``sigma`` [m] from the tag at ``position`` (3,) [m] to an
        anchor at ``anchor`` (3,) [m]: along the horizontal line to the anchor, scaled by
        how much of the slant range is horizontal."""
        diff = np.asarray(position, float)[:3] - np.asarray(anchor, float)[:3]
        slant = float(np.linalg.norm(diff))
        if not slant > 1e-6:
            return
        h = diff[:2] / slant
        s = float(h @ self.cov @ h) + sigma * sigma
        if not s > 0.0:
            return
        k = self.cov @ h / s
        self.cov = self.cov - np.outer(k, h @ self.cov)
