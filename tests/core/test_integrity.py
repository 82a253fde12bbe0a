"""Protection radii against independent expectations: Monte-Carlo containment of Gaussians
and exact quantiles of weighted samples."""
from __future__ import annotations

import math

import numpy as np
import pytest

from firenav_framework.integrity import (IntegrityParams, gaussian_protection_radius,
                                         sample_protection_radius, trusted)


def test_isotropic_gaussian_radius_is_the_rayleigh_quantile():
    # |e| of an isotropic 2-D Gaussian is Rayleigh: P(|e| < r) = 1 - exp(-r^2 / 2 s^2)
    s = 0.7
    r = gaussian_protection_radius(np.eye(2) * s * s, 0.99)
    assert 1 - math.exp(-r * r / (2 * s * s)) == pytest.approx(0.99, abs=1e-12)


@pytest.mark.parametrize("cov", [[[4.0, 0.0], [0.0, 0.01]], [[1.0, 0.8], [0.8, 1.0]],
                                 [[0.25, 0.0], [0.0, 0.25]]])
def test_gaussian_radius_contains_at_least_its_share(cov):
    rng = np.random.default_rng(3)
    e = rng.multivariate_normal([0.0, 0.0], cov, size=200_000)
    r = gaussian_protection_radius(np.array(cov), 0.99)
    inside = np.mean(np.hypot(e[:, 0], e[:, 1]) <= r)
    assert inside >= 0.99 - 0.001          # a bound: never fewer than promised
    assert inside <= 0.9999                # and not absurdly loose for these shapes


def test_non_finite_covariance_promises_nothing():
    assert gaussian_protection_radius(np.array([[np.nan, 0], [0, 1.0]])) == math.inf


def test_sample_radius_is_the_weighted_quantile_and_counts_a_second_mode():
    xy = np.array([[0.0, 0.0]] * 90 + [[10.0, 0.0]] * 10)
    w = np.ones(100)
    # 90 % of the weight at the centre, 10 % at 10 m: the 99 % radius must reach the far mode
    assert sample_protection_radius(xy, w, np.zeros(2), 0.99) == pytest.approx(10.0)
    assert sample_protection_radius(xy, w, np.zeros(2), 0.85) == pytest.approx(0.0)
    w2 = np.r_[np.ones(90), np.zeros(10)]
    assert sample_protection_radius(xy, w2, np.zeros(2), 0.99) == pytest.approx(0.0)
    assert sample_protection_radius(np.zeros((0, 2)), np.zeros(0), np.zeros(2)) == math.inf


def test_trusted_follows_the_alert_limit_and_contradictions():
    p = IntegrityParams(alert_limit=3.0)
    assert trusted(2.9, p) and not trusted(3.1, p) and not trusted(math.inf, p)
    assert not trusted(0.5, p, contradicted=True)
