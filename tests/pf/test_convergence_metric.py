"""The search-pattern paper's metric: RMSE after convergence, convergence judged by the
estimate's own variance (var_x + var_y below 3 m^2, Sec. V-E), never by the truth."""
from __future__ import annotations

import math

import numpy as np
import pytest

from firenav_framework.evaluation.metrics import (CONVERGED_HOLD_S, CONVERGED_VARIANCE_M2,
                                                  TrackErrors, metrics_of, pooled_metrics,
                                                  track_errors, variance_convergence_time)
from firenav_framework.evaluation.spread import spreads
from firenav_framework.tracks import Track


def _errors(t: np.ndarray, err: np.ndarray, var_xy: np.ndarray) -> TrackErrors:
    n = len(t)
    return TrackErrors("ff1", t, err, np.full(n, np.nan), np.full(n, np.nan), 10.0,
                       np.full(n, 1.0), np.full(n, np.inf), np.zeros(n, bool), var_xy)


def test_converges_when_the_variance_stays_below_the_paper_threshold():
    t = np.arange(0.0, 100.0, 0.5)
    var = np.where(t < 30.0, 12.0, 1.0)
    err = np.where(t < 30.0, 5.0, 0.8)
    m = metrics_of(_errors(t, err, var))
    assert m.variance_converge_s == pytest.approx(30.0)
    # the paper's metric: the RMSE of the errors from convergence on, not the whole run's
    assert m.rmse_after_convergence_m == pytest.approx(0.8)
    assert m.rmse_m == pytest.approx(math.sqrt(0.3 * 25 + 0.7 * 0.64))
    assert m.converged_fraction == 1.0


def test_a_dip_shorter_than_the_hold_does_not_count_and_a_later_rise_stays_in():
    t = np.arange(0.0, 100.0, 1.0)
    var = np.full(t.size, 8.0)
    var[10:10 + int(CONVERGED_HOLD_S) - 2] = 0.5     # a collapsed resampling, briefly
    var[50:] = 0.5
    var[80:85] = 6.0                                  # diverges later (a map error): counted
    err = np.where(t >= 80, 4.0, 1.0) * (t >= 50) + np.where(t < 50, 6.0, 0.0)
    assert variance_convergence_time(t, var) == pytest.approx(50.0)
    m = metrics_of(_errors(t, err, var))
    after = err[50:]
    assert m.rmse_after_convergence_m == pytest.approx(float(np.sqrt(np.mean(after ** 2))))


def test_never_converging_gives_none_and_nan_variance_is_above():
    t = np.arange(0.0, 60.0, 1.0)
    var = np.full(t.size, CONVERGED_VARIANCE_M2 + 0.01)
    var[20:] = np.nan
    m = metrics_of(_errors(t, np.ones(t.size), var))
    assert m.variance_converge_s is None and m.rmse_after_convergence_m is None
    assert m.converged_fraction == 0.0
    # below only for the last 5 s: not long enough to count
    var[-5:] = 1.0
    assert variance_convergence_time(t, var) is None


def test_pooled_over_tracks_and_spread_over_runs():
    t = np.arange(0.0, 100.0, 1.0)
    a = _errors(t, np.where(t < 10, 9.0, 1.0), np.where(t < 10, 9.0, 1.0))
    b = _errors(t, np.where(t < 40, 9.0, 2.0), np.where(t < 40, 9.0, 1.0))
    c = _errors(t, np.full(t.size, 7.0), np.full(t.size, 9.0))   # never converges
    pooled = pooled_metrics([a, b, c])
    assert pooled.converged_fraction == pytest.approx(2 / 3)
    assert pooled.variance_converge_s == pytest.approx(40.0)       # median of 10, 40, never
    after = np.concatenate([np.ones(90), np.full(60, 2.0)])
    assert pooled.rmse_after_convergence_m == pytest.approx(float(np.sqrt(np.mean(after ** 2))))
    # a never-converged run is infinitely late in the spread of the time
    sp = spreads([metrics_of(a), metrics_of(c), metrics_of(c)])
    assert sp["variance_converge_s"].median == math.inf
    assert sp["converged_fraction"].max == 1.0 and sp["converged_fraction"].min == 0.0


def test_track_errors_reads_the_variance_from_the_published_covariance():
    n = 50
    t = np.arange(n, dtype=float)
    cov = np.zeros((n, 4, 4))
    cov[:, 0, 0] = np.where(t < 20, 4.0, 0.6)
    cov[:, 1, 1] = np.where(t < 20, 4.0, 0.6)
    pos = np.zeros((n, 3))
    pos[:, 0] = np.where(t < 20, 3.0, 0.5)
    est = Track("ff1", t, pos, np.zeros(n), cov, np.full(n, -1), np.zeros(n, bool),
                np.full(n, np.inf))
    truth = Track("ff1", t, np.zeros((n, 3)), np.zeros(n), np.zeros((n, 4, 4)),
                  np.full(n, -1), np.zeros(n, bool), np.full(n, np.inf))
    err = track_errors(est, truth)
    np.testing.assert_allclose(err.var_xy, cov[:, 0, 0] + cov[:, 1, 1])
    m = metrics_of(err)
    assert m.variance_converge_s == pytest.approx(20.0)
    assert m.rmse_after_convergence_m == pytest.approx(0.5)
