"""Integrity figures against hand-worked and Monte-Carlo expectations."""
from __future__ import annotations

import numpy as np
import pytest

from firenav_framework.evaluation.metrics import metrics_of, pooled_metrics, track_errors
from firenav_framework.tracks import Track


def _track(t, xy, cov, pr, trusted, agent="ff1") -> Track:
    n = len(t)
    return Track(agent=agent, t=np.asarray(t, float),
                 position=np.column_stack([xy, np.zeros(n)]), heading=np.zeros(n),
                 cov=cov, floor=np.full(n, -1), trusted=np.asarray(trusted, bool),
                 protection_radius=np.asarray(pr, float))


def _truth(t) -> Track:
    n = len(t)
    return _track(t, np.zeros((n, 2)), np.full((n, 4, 4), np.nan), np.full(n, np.inf),
                  np.ones(n, bool))


def test_a_consistent_gaussian_estimate_scores_as_promised():
    rng = np.random.default_rng(7)
    n = 40_000
    t = np.arange(n) * 0.1
    cov2 = np.array([[0.5, 0.2], [0.2, 0.3]])
    err = rng.multivariate_normal([0, 0], cov2, size=n)
    cov = np.tile(np.eye(4), (n, 1, 1))
    cov[:, :2, :2] = cov2
    m = metrics_of(track_errors(_track(t, err, cov, np.full(n, 10.0), np.ones(n)), _truth(t)))
    assert m.ellipse95_containment == pytest.approx(0.95, abs=0.005)
    assert m.nees_xy == pytest.approx(2.0, abs=0.05)
    assert m.protection_containment == 1.0 and m.trusted_fraction == 1.0
    assert m.trusted_off_fraction == pytest.approx(np.mean(np.hypot(*err.T) > 3.0))


def test_confidently_wrong_poses_are_counted_over_all_poses():
    t = np.arange(10.0)
    xy = np.column_stack([[0, 0, 0, 0, 0, 4, 4, 4, 5, 5], np.zeros(10)])
    trusted = [1, 1, 1, 1, 1, 1, 0, 0, 1, 0]      # 2 of 10 trusted while 4-5 m off
    pr = [1, 1, 1, 1, 1, 1, 1, 1, 9, np.inf]       # radius exceeded at 5, 6, 7 (9 holds 5 m)
    cov = np.tile(np.eye(4) * 0.01, (10, 1, 1))
    m = metrics_of(track_errors(_track(t, xy, cov, pr, trusted), _truth(t)))
    assert m.trusted_off_fraction == pytest.approx(0.2)
    assert m.trusted_fraction == pytest.approx(0.7)
    assert m.protection_containment == pytest.approx(6 / 9)   # the infinite radius promises nothing


def test_degenerate_covariances_are_left_out_and_pooling_keeps_every_sample():
    t = np.arange(4.0)
    cov = np.tile(np.eye(4), (4, 1, 1))
    cov[0] = np.nan
    cov[1, :2, :2] = 0.0
    a = track_errors(_track(t, np.full((4, 2), 2.0), cov, np.full(4, 2.0), np.ones(4)), _truth(t))
    assert np.isnan(a.mahalanobis2[:2]).all() and np.allclose(a.mahalanobis2[2:], 8.0)
    b = track_errors(_track(t, np.zeros((4, 2)), np.tile(np.eye(4), (4, 1, 1)), np.full(4, 2.0),
                            np.zeros(4), agent="ff2"), _truth(t))
    pooled = pooled_metrics([a, b])
    assert pooled.trusted_fraction == pytest.approx(0.5)
    assert pooled.ellipse95_containment == pytest.approx(4 / 6)
