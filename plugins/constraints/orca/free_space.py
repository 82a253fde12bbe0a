"""What the walls around a position know of it: the free space either side, as a covariance.

Every step that no jump moved is somewhere between the first walls either side of the
corrected position, along and across the heading (a corridor's width, a room's
extent); ``dead_reckoning`` fuses that as evidence that repeats from step to step.
"""
from __future__ import annotations

import math

import numpy as np

from firenav_framework.capabilities.odometry_correction import UNKNOWN_VARIANCE

from ..corrections import axes_covariance
from ..segment_hits import SegmentHits

__all__ = ["free_space_covariance"]


def free_space_covariance(walls: SegmentHits, position: np.ndarray, heading: float,
                          reach: float) -> np.ndarray | None:
    """A measurement covariance (2, 2) [m^2] of ``position`` (2,) [m] on the axes along
    and across ``heading`` [rad] from the ``walls`` of its floor, or None if neither
    axis meets walls within ``reach`` [m] on both sides.

    Along each axis the walker is somewhere between the first walls either side (a and b
    metres away), taken as uniform over that extent: the mean squared error of the
    estimate is (a^3 + b^3) / (3 (a + b)). An axis open beyond ``reach`` on either side
    is not measured.
    """
    c, s = math.cos(heading), math.sin(heading)
    x, y = float(position[0]), float(position[1])
    r = reach
    p0 = np.array([[x, y], [x, y], [x, y], [x, y]])
    p1 = np.array([[x + r * c, y + r * s], [x - r * s, y + r * c],
                   [x - r * c, y - r * s], [x + r * s, y - r * c]])   # +-along, +-across
    frac, which = walls.first_hit(p0, p1)
    var = [UNKNOWN_VARIANCE, UNKNOWN_VARIANCE]
    for k in (0, 1):
        if which[k] >= 0 and which[k + 2] >= 0:
            a, b = r * float(frac[k]), r * float(frac[k + 2])
            var[k] = max((a ** 3 + b ** 3) / (3.0 * max(a + b, 1e-9)), 1e-4)
    if var[0] == var[1] == UNKNOWN_VARIANCE:
        return None
    return axes_covariance(np.array([[c, -s], [s, c]]), np.array(var))
