"""Integrity of a pose: how far off it may be, and whether to trust it.

Every :class:`~firenav_framework.messages.PoseEstimate` carries a *protection radius*:
the horizontal distance [m] the true position is within with probability
``containment`` (99 % by default) as far as the estimator knows. ``trusted`` is derived
from it: a pose is trusted only while its protection radius is within the alert limit
the commander works to (:class:`IntegrityParams.alert_limit`, 3 m by default: about one
room's depth) and the estimator sees nothing contradicting it (a plan its motion cannot
follow, a read from a door it cannot be at). Both are promises the evaluation measures
(``firenav evaluate`` reports how often the error exceeds the radius, and how often a
pose is trusted while more than the alert limit off).

Radii:

* :func:`gaussian_protection_radius` for a Gaussian estimate (an EKF, a graph): the
  circle that holds ``containment`` of the isotropic Gaussian with the largest
  eigenvalue of the horizontal covariance, which bounds the true elliptic case from
  above: ``r = sigma_max * sqrt(-2 ln(1 - containment))`` (3.03 sigma at 99 %).
* :func:`sample_protection_radius` for a weighted sample (a particle cloud, several
  hypotheses): the weighted ``containment`` quantile of the samples' distances from the
  reported position, so a second mode counts in full.
"""
from __future__ import annotations

import math

import numpy as np

from .contract.params import Params, param

__all__ = ["IntegrityParams", "gaussian_protection_radius", "sample_protection_radius",
           "trusted", "DEFAULT_CONTAINMENT", "DEFAULT_ALERT_LIMIT"]

DEFAULT_CONTAINMENT = 0.99
DEFAULT_ALERT_LIMIT = 3.0


class IntegrityParams(Params):
    """When a pose is trusted: the estimator-side half of the integrity promise."""

    alert_limit: float = param(DEFAULT_ALERT_LIMIT, unit="m", gt=0)
    """a pose whose protection radius exceeds this is not trusted"""
    containment: float = param(DEFAULT_CONTAINMENT, gt=0.5, lt=1.0)
    """probability that the horizontal error is within the protection radius"""


def gaussian_protection_radius(cov_xy: np.ndarray,
                               containment: float = DEFAULT_CONTAINMENT) -> float:
    """Protection radius [m] of a Gaussian with horizontal covariance ``cov_xy`` (2, 2) [m^2].

    Non-finite covariances give ``inf`` (nothing is promised).
    """
    c = np.asarray(cov_xy, float)[:2, :2]
    if not np.all(np.isfinite(c)):
        return math.inf
    a, b, d = c[0, 0], 0.5 * (c[0, 1] + c[1, 0]), c[1, 1]
    lam_max = 0.5 * (a + d) + math.hypot(0.5 * (a - d), b)
    return math.sqrt(max(lam_max, 0.0) * -2.0 * math.log1p(-containment))


def sample_protection_radius(xy: np.ndarray, weights: np.ndarray, centre: np.ndarray,
                             containment: float = DEFAULT_CONTAINMENT) -> float:
    """Protection radius [m] of weighted samples ``xy`` (N, 2) about ``centre`` (2,).

    The smallest radius whose disc about ``centre`` holds ``containment`` of the weight
    (``weights`` need not be normalised). An empty or weightless sample gives ``inf``.
    """
    xy = np.asarray(xy, float).reshape(-1, 2)
    w = np.asarray(weights, float)
    total = float(np.sum(w))
    if not len(xy) or not total > 0 or not math.isfinite(total):
        return math.inf
    d = np.hypot(xy[:, 0] - centre[0], xy[:, 1] - centre[1])
    order = np.argsort(d)
    cum = np.cumsum(w[order]) / total
    i = int(np.searchsorted(cum, containment - 1e-12))
    return float(d[order[min(i, len(d) - 1)]])


def trusted(protection_radius: float, params: IntegrityParams,
            contradicted: bool = False) -> bool:
    """Whether a pose with this protection radius [m] may be trusted (see the module)."""
    return (not contradicted) and math.isfinite(protection_radius) and \
        protection_radius <= params.alert_limit
