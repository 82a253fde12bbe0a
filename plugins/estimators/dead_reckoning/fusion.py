"""A constraint's measurement covariance fused into the dead-reckoning covariance.

A correction that says how well it knows the corrected position (``StepCorrection.cov``:
tight across a wall the step touched, along the line to a UWB anchor) is a measurement
of the position states (x, y) of the estimator's covariance; a Kalman update in Joseph
form brings the position covariance down there and, through the correlations the drift
states built up, the heading and its rate with it. Each principal axis of the
measurement covariance is one scalar update; axes of :data:`UNKNOWN_VARIANCE` are not
measured and are skipped.

Evidence that repeats from step to step (``independent`` False: the same wall touched
on every step of a run along it) is not new evidence each time: it only brings the
variance along its axis down *to* the measurement's variance, never below (the scalar
update's noise is chosen so that the posterior variance equals it).
"""
from __future__ import annotations

import numpy as np

from firenav_framework.capabilities.odometry_correction import UNKNOWN_VARIANCE

__all__ = ["fuse_position"]


def fuse_position(cov: np.ndarray, meas: np.ndarray, independent: bool = True) -> np.ndarray:
    """The covariance (n, n) after fusing a position measurement of covariance ``meas``
    (2, 2) [m^2] on states 0 and 1 (x, y [m]) of ``cov`` (n, n)."""
    values, axes = np.linalg.eigh(0.5 * (meas + meas.T))
    out = cov
    n = cov.shape[0]
    for r, u in zip(values, axes.T):
        if not 0.0 < r < 0.5 * UNKNOWN_VARIANCE:
            continue
        h = np.zeros(n)
        h[:2] = u
        ph = out @ h
        prior = float(h @ ph)
        if not independent:
            if prior <= r:
                continue                  # already known that well: nothing new
            r = r * prior / (prior - r)   # the noise whose update ends at variance r
        k = ph / (prior + r)
        a = np.eye(n) - np.outer(k, h)
        out = a @ out @ a.T + r * np.outer(k, k)
    return out
