"""How the odometry-correction constraints (``orca``, ``anchor_range``, ``wall_follow``)
state their answer to a step: the corrected position at the step's height, and what a
constraint knows of that position as a covariance on two axes.
"""
from __future__ import annotations

import numpy as np

from firenav_framework.capabilities.odometry_correction import OdometryStep, StepCorrection

__all__ = ["axes_covariance", "correction"]


def correction(step: OdometryStep, xy: np.ndarray, **fields) -> StepCorrection:
    """The :class:`StepCorrection` putting the agent at ``xy`` (2,) [m] (ENU), at the
    height of the step's proposed position; ``fields`` are the other fields (update,
    jump, event, cov, independent)."""
    return StepCorrection(position=np.array([xy[0], xy[1], step.proposed[2]]), **fields)


def axes_covariance(axes: np.ndarray, variances: np.ndarray) -> np.ndarray:
    """The covariance (2, 2) [m^2] with ``variances`` (2,) [m^2] along the orthonormal
    ``axes`` (2, 2), one axis per column (:data:`UNKNOWN_VARIANCE` for an axis that is
    not measured)."""
    return (axes * variances) @ axes.T
