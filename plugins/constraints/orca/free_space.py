"""What the walls around a position know of it: the free space either side, as a covariance.

Every step that no jump moved is somewhere between the first walls either side of the
corrected position, along and across the heading (a corridor's width, a room's
extent); ``dead_reckoning`` fuses that as evidence that repeats from step to step.

That evidence holds only if the walker is in the compartment the track is in. Where the
estimator's own covariance says the walker may well be beyond those walls (after a
door or reset jump, a contradicted correction, or drift with no radio), the walls of
the track's compartment say nothing of the true position, and the axis is not measured:
otherwise one step in a wrong room would shrink the widened covariance back to the
room's size, and the track would be trusted there.
"""
from __future__ import annotations

import math

import numpy as np

from firenav_framework.capabilities.odometry_correction import UNKNOWN_VARIANCE

from ..corrections import axes_covariance
from ..segment_hits import SegmentHits

__all__ = ["free_space_covariance", "inside_probability"]


def free_space_covariance(walls: SegmentHits, position: np.ndarray, heading: float,
                          reach: float, prior: np.ndarray | None = None,
                          confidence: float = 0.0) -> np.ndarray | None:
    """A measurement covariance (2, 2) [m^2] of ``position`` (2,) [m] on the axes along
    and across ``heading`` [rad] from the ``walls`` of its floor, or None if no axis is
    measured.

    Along each axis the walker is somewhere between the first walls either side (a and b
    metres away), taken as uniform over that extent: the mean squared error of the
    estimate is (a^3 + b^3) / (3 (a + b)). An axis open beyond ``reach`` on either side
    is not measured, nor one where ``prior`` (2, 2) [m^2], the covariance of the
    position's error before this evidence, puts the walker between those walls with a
    probability below ``confidence`` (:func:`inside_probability`).
    """
    c, s = math.cos(heading), math.sin(heading)
    x, y = float(position[0]), float(position[1])
    r = reach
    p0 = np.array([[x, y], [x, y], [x, y], [x, y]])
    p1 = np.array([[x + r * c, y + r * s], [x - r * s, y + r * c],
                   [x - r * c, y - r * s], [x + r * s, y - r * c]])   # +-along, +-across
    frac, which = walls.first_hit(p0, p1)
    axes = np.array([[c, -s], [s, c]])
    var = [UNKNOWN_VARIANCE, UNKNOWN_VARIANCE]
    for k in (0, 1):
        if which[k] >= 0 and which[k + 2] >= 0:
            a, b = r * float(frac[k]), r * float(frac[k + 2])
            if prior is not None and inside_probability(prior, axes[:, k], a, b) < confidence:
                continue
            var[k] = max((a ** 3 + b ** 3) / (3.0 * max(a + b, 1e-9)), 1e-4)
    if var[0] == var[1] == UNKNOWN_VARIANCE:
        return None
    return axes_covariance(axes, np.array(var))


def inside_probability(prior: np.ndarray, axis: np.ndarray, a: float, b: float) -> float:
    """The probability that an error of covariance ``prior`` (2, 2) [m^2] lies between
    ``-b`` and ``a`` [m] along the unit ``axis`` (2,): the walker is between the walls
    ``a`` metres ahead and ``b`` metres behind the estimate on that axis."""
    var = float(axis @ prior @ axis)
    if not var > 0.0:
        return 1.0
    scale = math.sqrt(2.0 * var)
    return 0.5 * (math.erf(a / scale) + math.erf(b / scale))
