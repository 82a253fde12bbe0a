"""Metrics and checkpoint evaluation against hand-made tracks with known errors."""
from __future__ import annotations

import numpy as np
import pytest

from firenav_framework.evaluation import (Checkpoints, checkpoint_errors, fit_rigid_2d,
                                          metrics_of, pooled_metrics, track_errors)
from firenav_framework.evaluation.checkpoints import is_sparse, parse_align
from firenav_framework.evaluation.metrics import convergence_time, error_stats
from firenav_framework.tracks import Track


def make_track(t, xy, z=None, floor=None, agent="a") -> Track:
    t = np.asarray(t, float)
    xy = np.asarray(xy, float)
    n = len(t)
    pos = np.column_stack([xy, np.zeros(n) if z is None else z])
    return Track(agent=agent, t=t, position=pos, heading=np.zeros(n),
                 cov=np.tile(np.eye(4) * 0.01, (n, 1, 1)),
                 floor=np.full(n, -1) if floor is None else np.asarray(floor),
                 trusted=np.ones(n, bool), protection_radius=np.full(n, np.inf))


def straight_truth(speed=1.0, duration=100.0, rate=20.0, floor=0):
    t = np.arange(0.0, duration + 1e-9, 1.0 / rate)
    return make_track(t, np.column_stack([speed * t, np.zeros_like(t)]),
                      floor=np.full(len(t), floor))


def test_constant_offset_gives_exact_figures():
    truth = straight_truth()
    t = np.arange(0.0, 100.0, 0.5)
    est = make_track(t, np.column_stack([t, np.full_like(t, 3.0)]), z=np.full_like(t, 0.4),
                     floor=np.zeros(len(t), int))
    m = metrics_of(track_errors(est, truth))
    for key in ("rmse_m", "mean_m", "median_m", "p90_m", "p95_m", "max_m"):
        assert getattr(m, key) == pytest.approx(3.0)
    assert m.distance_m == pytest.approx(99.5)              # true path over the span
    assert m.mean_pct_distance == pytest.approx(300.0 / 99.5)
    assert m.vertical_rmse_m == pytest.approx(0.4)
    assert m.floor_accuracy == 1.0
    assert m.converge_s is None                              # 3 m never below 2 m
    assert metrics_of(track_errors(est, truth), bound_m=5.0).converge_s == 0.0


def test_breadcrumb_papers_error_factor():
    """Mean 5.6 m and max 10.9 m over 400 m are 1.4 % and 2.7 % (paper Sec. V-A)."""
    truth = straight_truth(speed=4.0, duration=100.0)
    t = np.linspace(0.0, 100.0, 1001)
    err = np.full_like(t, 5.6)
    err[500] = 10.9
    est = make_track(t, np.column_stack([4.0 * t, err]))
    m = metrics_of(track_errors(est, truth))
    assert m.distance_m == pytest.approx(400.0)
    assert m.mean_pct_distance == pytest.approx(100 * (5.6 + 5.3 / 1001) / 400, rel=1e-6)
    assert m.max_pct_distance == pytest.approx(100 * 10.9 / 400)


def test_convergence_is_when_the_error_stays_below_the_bound():
    t = np.arange(0.0, 10.0, 1.0)
    e = np.array([9, 5, 1, 3, 1.5, 1, 0.5, 0.5, 0.2, 0.1])
    assert convergence_time(t, e, 2.0) == pytest.approx(4.0)     # after the 3 m at t = 3
    assert convergence_time(t, e, 0.05) is None
    assert convergence_time(t + 5.0, e, 10.0) == 0.0


def test_vertical_floor_and_unknowns():
    truth = straight_truth(floor=1)
    t = np.arange(0.0, 100.0, 1.0)
    est = make_track(t, np.column_stack([t, np.zeros_like(t)]), z=np.full_like(t, np.nan),
                     floor=np.where(t < 75, 1, 0))
    m = metrics_of(track_errors(est, truth))
    assert m.floor_accuracy == pytest.approx(0.75)
    assert m.vertical_rmse_m is None
    unknown = make_track(t, np.column_stack([t, np.zeros_like(t)]))
    assert metrics_of(track_errors(unknown, truth)).floor_accuracy is None


def test_estimates_outside_the_truth_span_are_not_scored():
    truth = straight_truth(duration=50.0)
    t = np.arange(-10.0, 80.0, 1.0)
    est = make_track(t, np.column_stack([t, np.ones_like(t)]))
    e = track_errors(est, truth)
    assert e.t.min() == 0.0 and e.t.max() == 50.0 and len(e.t) == 51


def test_pooled_metrics_pool_samples_and_average_percentages():
    truth = straight_truth(duration=100.0)
    t = np.arange(0.0, 100.0, 1.0)
    a = track_errors(make_track(t, np.column_stack([t, np.full_like(t, 1.0)])), truth)
    b = track_errors(make_track(t, np.column_stack([t, np.full_like(t, 3.0)])), truth)
    m = pooled_metrics([a, b])
    assert m.rmse_m == pytest.approx(np.sqrt((1 + 9) / 2))
    assert m.max_m == 3.0
    assert m.mean_pct_distance == pytest.approx((100 / 99 + 300 / 99) / 2)
    assert m.converge_s is None            # half of the tracks never converge
    assert pooled_metrics([a, a, b]).converge_s == 0.0
    assert pooled_metrics([]).rmse_m is None


def test_rigid_fit_recovers_a_rotation_and_translation():
    rng = np.random.default_rng(1)
    src = rng.uniform(-10, 10, (20, 2))
    ang = 0.7
    r = np.array([[np.cos(ang), -np.sin(ang)], [np.sin(ang), np.cos(ang)]])
    dst = src @ r.T + [3.0, -2.0]
    rf, tf = fit_rigid_2d(src, dst)
    assert np.allclose(rf, r) and np.allclose(tf, [3.0, -2.0])
    r1, t1 = fit_rigid_2d(src[:1], dst[:1])
    assert np.allclose(r1, np.eye(2)) and np.allclose(t1, dst[0] - src[0])


def test_checkpoint_evaluation_with_stated_alignments():
    """An INS track in its own frame: rotated by 30 deg and shifted, drifting slowly."""
    t = np.arange(0.0, 100.0, 0.5)
    path = np.column_stack([t, 5 * np.sin(t / 10)])
    ang = np.radians(30)
    r = np.array([[np.cos(ang), -np.sin(ang)], [np.sin(ang), np.cos(ang)]])
    drift = np.column_stack([np.zeros_like(t), 0.002 * t ** 2])      # grows to 20 m
    ins = make_track(t, (path + drift) @ r.T + [50.0, 7.0])
    k = np.arange(0, len(t), 10)
    cps = Checkpoints("a", t[k], np.column_stack([path[k], np.zeros(len(k))]), np.full(len(k), -1))
    none, _ = checkpoint_errors(ins, cps, align="none")
    first, _ = checkpoint_errors(ins, cps, align="first:3")
    full, _ = checkpoint_errors(ins, cps, align="all")
    assert none.horizontal.mean() > 30                       # frames differ
    assert first.horizontal[:3].max() < 0.1                  # fitted where drift is ~0
    assert first.horizontal[-1] == pytest.approx(drift[k[-1], 1], rel=0.1)
    assert full.horizontal.mean() < first.horizontal.mean()  # optimistic
    assert first.distance_m == pytest.approx(
        np.sum(np.hypot(*np.diff(path[k], axis=0).T)))


def test_checkpoints_outside_the_estimate_are_counted_and_align_is_checked():
    est = make_track(np.arange(10.0, 20.0), np.zeros((10, 2)))
    cps = Checkpoints("a", np.array([5.0, 12.0, 15.0, 25.0]), np.zeros((4, 3)), np.full(4, -1))
    err, outside = checkpoint_errors(est, cps)
    assert outside == 2 and len(err.t) == 2
    assert parse_align("first") == ("first", 2) and parse_align("first:5") == ("first", 5)
    for bad in ("first:0", "best", "first:x"):
        with pytest.raises(ValueError, match="none, all or first:K"):
            parse_align(bad)
    assert is_sparse(make_track(np.arange(0, 10.0), np.zeros((10, 2))))
    assert not is_sparse(straight_truth())


def test_error_stats_skip_non_finite_values():
    s = error_stats(np.array([1.0, np.nan, 3.0, np.inf]))
    assert s.n == 2 and s.mean_m == 2.0


def test_between_floors_either_neighbouring_floor_is_right():
    from firenav_framework.evaluation.metrics import floor_right
    levels = np.array([0.0, 3.5, 7.0])
    z_true = np.array([0.0, 1.75, 1.75, 1.75, 3.5, 3.4, 5.0])
    floor_true = np.array([0, 0, 1, 0, 1, 1, 1])   # the 1.75 m landing is a coin toss
    floor_est = np.array([0, 1, 0, 2, 0, 1, 2])
    np.testing.assert_array_equal(floor_right(floor_est, floor_true, z_true, levels),
                                  [1, 1, 1, 0, 0, 1, 1])
    # without the levels only the labelled floor counts; unknown floors are NaN
    got = floor_right(np.array([0, 1, -1]), np.array([0, 0, 0]), np.zeros(3), None)
    np.testing.assert_array_equal(got[:2], [1, 0])
    assert np.isnan(got[2])
