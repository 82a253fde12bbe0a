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

import math

import numpy as np

from firenav_framework.capabilities.odometry_correction import UNKNOWN_VARIANCE

__all__ = ["fuse_position"]


def fuse_position(cov: np.ndarray, meas: np.ndarray, independent: bool = True) -> np.ndarray:
    """The covariance (n, n) after fusing a position measurement of covariance ``meas``
    (2, 2) [m^2] on states 0 and 1 (x, y [m]) of ``cov`` (n, n)."""
    out = cov
    for r, ux, uy in _principal_axes(meas):
        if not 0.0 < r < 0.5 * UNKNOWN_VARIANCE:
            continue
        ph = out[:, 0] * ux + out[:, 1] * uy        # P h, h = (ux, uy, 0, ...)
        prior = float(ph[0] * ux + ph[1] * uy)
        if not independent:
            if prior <= r:
                continue                  # already known that well: nothing new
            r = r * prior / (prior - r)   # the noise whose update ends at variance r
        k = ph / (prior + r)
        # Joseph form (I - k h') P (I - k h')' + r k k', as two rank-one steps
        left = out - np.outer(k, ph)                # (I - k h') P
        out = left - np.outer(left[:, 0] * ux + left[:, 1] * uy, k) + r * np.outer(k, k)
    return out


def _principal_axes(meas: np.ndarray) -> tuple[tuple[float, float, float], ...]:
    """The variances [m^2] and unit axes of the symmetric part of ``meas`` (2, 2), the
    smaller variance first (as ``numpy.linalg.eigh``)."""
    a, d = float(meas[0, 0]), float(meas[1, 1])
    b = 0.5 * (float(meas[0, 1]) + float(meas[1, 0]))
    half = 0.5 * (a - d)
    big = 0.5 * (a + d) + math.hypot(half, b)
    small = (a * d - b * b) / big if big != 0.0 else 0.0   # no cancellation when a >> d
    angle = 0.5 * math.atan2(b, half)                  # direction of the larger variance
    c, s = math.cos(angle), math.sin(angle)
    return (small, -s, c), (big, c, s)
