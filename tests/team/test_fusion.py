"""team_fusion's fusion core and estimator against analytic expectations: covariance
intersection of two and three Gaussians, the consistency gate, rival hypotheses."""
from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from firenav_framework import Odometry, PoseEstimate
from firenav_framework.integrity import gaussian_protection_radius
from firenav_framework.testing import Session
from firenav_plugins.estimators.team_fusion import TeamFusionEstimator
from firenav_plugins.estimators.team_fusion.quality import InputQuality
from firenav_plugins.estimators.team_fusion.fusion import (chi2_2dof_quantile, gate_matrix,
                                                           consistent_hypotheses,
                                                           covariance_intersection)


def _det_of_ci(covs, w):
    return float(np.linalg.det(np.linalg.inv(sum(wi * np.linalg.inv(c) for wi, c in zip(w, covs)))))


def test_two_symmetric_gaussians_give_the_analytic_ci():
    # A = diag(1, 4), B = diag(4, 1): by symmetry omega = 1/2, P = (A^-1/2 + B^-1/2)^-1
    # = diag(1.6, 1.6); x = P (A^-1 a + B^-1 b) / 2 with a = 0, b = (1, 1): (0.2, 0.8)
    a, b = np.diag([1.0, 4.0]), np.diag([4.0, 1.0])
    mean, cov, w = covariance_intersection(np.array([a, b]), np.array([[0.0, 0.0], [1.0, 1.0]]))
    np.testing.assert_allclose(w, [0.5, 0.5], atol=1e-6)
    np.testing.assert_allclose(cov, np.diag([1.6, 1.6]), atol=1e-6)
    np.testing.assert_allclose(mean, [0.2, 0.8], atol=1e-6)


def test_two_general_gaussians_match_the_det_minimising_omega():
    a = np.array([[2.0, 0.7], [0.7, 0.5]])
    b = np.array([[0.6, -0.2], [-0.2, 3.0]])
    xa, xb = np.array([1.0, -1.0]), np.array([1.5, 0.2])
    mean, cov, w = covariance_intersection(np.array([a, b]), np.array([xa, xb]))
    # independent: a fine scan of omega for the least det P
    omegas = np.linspace(0.0, 1.0, 200001)
    dets = [_det_of_ci([a, b], (o, 1 - o)) for o in omegas[1:-1]]
    o = omegas[1:-1][int(np.argmin(dets))]
    assert w[0] == pytest.approx(o, abs=2e-4)
    p = np.linalg.inv(o * np.linalg.inv(a) + (1 - o) * np.linalg.inv(b))
    np.testing.assert_allclose(cov, p, rtol=1e-4)
    np.testing.assert_allclose(mean, p @ (o * np.linalg.solve(a, xa) + (1 - o) * np.linalg.solve(b, xb)),
                               atol=1e-4)


def test_three_gaussians_no_simplex_point_has_a_smaller_det():
    rng = np.random.default_rng(3)
    covs = []
    for _ in range(3):
        m = rng.normal(size=(2, 2))
        covs.append(m @ m.T + 0.2 * np.eye(2))
    covs = np.array(covs)
    _, cov, w = covariance_intersection(covs, rng.normal(size=(3, 2)))
    assert w.sum() == pytest.approx(1.0) and np.all(w >= 0)
    best = min(_det_of_ci(covs, (i / 100, j / 100, 1 - (i + j) / 100))
               for i, j in itertools.product(range(101), range(101)) if i + j <= 100
               and 0 < i and 0 < j and i + j < 100)
    # the fixed point converges sublinearly: within 0.1 % of the least det in 100 steps
    assert np.linalg.det(cov) <= best * (1 + 1e-3)


def test_ci_stays_consistent_when_the_inputs_share_their_error():
    # two estimates of the same point with a common error (as two methods fed by the
    # same INS): the fused covariance must still cover the fused error (NEES ~<= 2)
    # (cross-covariance S, each marginal as declared)
    rng = np.random.default_rng(7)
    ca, cb, shared_cov = np.diag([1.0, 0.3]), np.diag([0.3, 1.0]), np.eye(2) * 0.25
    m2 = []
    for _ in range(4000):
        shared = rng.multivariate_normal([0, 0], shared_cov)
        ea = shared + rng.multivariate_normal([0, 0], ca - shared_cov)
        eb = shared + rng.multivariate_normal([0, 0], cb - shared_cov)
        mean, cov, _ = covariance_intersection(np.array([ca, cb]), np.array([ea, eb]))
        m2.append(float(mean @ np.linalg.solve(cov, mean)))
    assert np.mean(m2) <= 2.0
    # the same data fused as if independent (the Kalman product) is overconfident
    p_ind = np.linalg.inv(np.linalg.inv(ca) + np.linalg.inv(cb))
    assert np.trace(p_ind) < np.trace(cov)


def test_gate_leaves_out_the_contradicting_input():
    covs = np.array([np.eye(2) * 0.25] * 3)
    means = np.array([[0.0, 0.0], [0.4, 0.1], [6.0, 0.0]])
    hyps = consistent_hypotheses(means, covs, [0, 0, 0], chi2_2dof_quantile(0.999))
    assert len(hyps) == 1 and hyps[0].members == (0, 1)


def test_two_inputs_that_disagree_are_rival_hypotheses():
    covs = np.array([np.eye(2) * 0.25] * 2)
    means = np.array([[0.0, 0.0], [6.0, 0.0]])
    hyps = consistent_hypotheses(means, covs, [0, 0], chi2_2dof_quantile(0.999))
    assert sorted(h.members for h in hyps) == [(0,), (1,)]


# ---- the estimator -------------------------------------------------------------------

def _odometry(t, x):
    return Odometry(t=t, agent="ff1", device="ff1/imu", t_start=t - 1.0,
                    delta=np.array([1.0, 0.0, 0.0]), dheading=0.0, cov=np.eye(4) * 1e-4,
                    position=np.array([x, 0.0, 0.0]), heading=0.0)


def _pose(t, x, y, sigma, floor=0):
    cov = np.diag([sigma ** 2, sigma ** 2, 0.01, 0.01])
    return PoseEstimate(t=t, agent="ff1", device="ff1/imu", position=np.array([x, y, 0.0]),
                        heading=0.0, cov=cov, floor=floor)


def _run(poses_at, params=None):
    """Odometry steps 1 m east each second; the poses of ``poses_at(t, x)`` before each."""
    session = Session(TeamFusionEstimator, params or {})
    msgs = []
    for k in range(1, 21):
        t, x = float(k), float(k)
        msgs += poses_at(t, x)
        msgs.append(("dr.odometry", _odometry(t, x)))
    rec = session.run(msgs)
    return rec.on("pose"), session, rec


def test_estimator_rejects_an_input_that_contradicts_the_others():
    poses, session, rec = _run(lambda t, x: [
        ("a.pose", _pose(t, x + 0.1, 0.0, 0.5)), ("b.pose", _pose(t, x - 0.1, 0.1, 0.5)),
        ("c.pose", _pose(t, x + 8.0, 5.0, 0.5))], {"quality": {"enabled": False}})
    # before the odometry starts the first step is fused at each input pose (a alone,
    # a + b, all three); then one pose per step from all three
    assert [p.t for p in poses] == [1.0, 1.0, 1.0] + [float(k) for k in range(2, 21)]
    err = [math.hypot(p.position[0] - p.t, p.position[1]) for p in poses]
    assert max(err) < 0.3
    # trusted once two inputs vouch for it; the first pose (a alone) is not
    assert all(p.trusted for p in poses[1:]) and not poses[0].trusted
    assert session.stats.counts["under_test"]["rejected:c.pose"] == 20
    assert "rejected:a.pose" not in session.stats.counts["under_test"]
    codes = {d.code for d in rec.on("diagnostics")}
    assert "input_rejected" in codes
    for p in poses:
        assert p.protection_radius == pytest.approx(gaussian_protection_radius(p.cov[:2, :2]))


def test_a_second_input_vouches_up_to_the_support_radius():
    """A tight input (0.3 m) is trusted with a second input whose own 99 % radius
    (3.03 sigma) is within `support.radius` (10 m): sigma 3 m (9.1 m) vouches, 3.5 m
    (10.6 m) does not, and the tight input alone is never trusted."""
    for sigma, vouches in ((3.0, True), (3.5, False)):
        poses, _, _ = _run(lambda t, x: [("a.pose", _pose(t, x, 0.0, 0.3)),
                                         ("b.pose", _pose(t, x, 0.0, sigma))],
                           {"quality": {"enabled": False}})
        assert all(p.protection_radius <= 3.0 for p in poses)
        assert [p.trusted for p in poses[1:]] == [vouches] * (len(poses) - 1)
        assert not poses[0].trusted         # a alone, before b's first pose


def test_a_contradicting_input_is_widened_online_and_never_pulls():
    # the same inputs with the learned factors: c is left out until its factor has
    # grown to hold its 9.4 m offset, then it agrees and is fused with a weight too
    # small to move the pose
    poses, session, _ = _run(lambda t, x: [
        ("a.pose", _pose(t, x + 0.1, 0.0, 0.5)), ("b.pose", _pose(t, x - 0.1, 0.1, 0.5)),
        ("c.pose", _pose(t, x + 8.0, 5.0, 0.5))])
    err = [math.hypot(p.position[0] - p.t, p.position[1]) for p in poses]
    assert max(err) < 0.3
    counts = session.stats.counts["under_test"]
    assert 1 <= counts["rejected:c.pose"] < 19
    quality = session.component.state["ff1"].quality
    assert quality.factor("c.pose") > 50 and quality.factor("a.pose") == 1.0


def test_learned_factor_is_the_weighted_mean_disagreement_times_the_margin():
    # a constant disagreement q = d^T (P + R)^-1 d / 2 each second: after N seconds the
    # exponentially weighted mean (time constant tau, from 0) is q (1 - exp(-N / tau))
    tau, margin = 30.0, 8.0
    quality = InputQuality(tau, 1e4, margin)
    d, p, r = np.array([3.0, 4.0]), np.eye(2) * 0.5, np.eye(2) * 0.75
    for k in range(41):
        quality.update("x.pose", float(k), d, p, np.zeros(2), r)
    q = 25.0 / (2 * 1.25)
    assert quality.factor("x.pose") == pytest.approx(margin * q * (1 - math.exp(-40 / tau)))
    # an input that agrees is never made tighter than its own covariance
    for k in range(41):
        quality.update("y.pose", float(k), np.zeros(2), p, np.zeros(2), r)
    assert quality.factor("y.pose") == 1.0
    assert quality.factor("unknown.pose") == 1.0


def test_a_step_waits_for_the_inputs_that_answer_after_the_odometry():
    # the methods publish their pose of a stride after the odometry of it (they run on
    # it): the step is fused with those poses, once, not with the poses of the stride before
    msgs = []
    for k in range(1, 11):
        t = float(k)
        msgs.append(("dr.odometry", _odometry(t, t)))
        msgs.append(("a.pose", _pose(t, t, 0.3 * k, 0.5)))
    rec = Session(TeamFusionEstimator, {}).run(msgs)
    poses = rec.on("pose")
    # (the first step has no input yet: nothing to publish)
    assert [p.t for p in poses] == [float(k) for k in range(2, 11)]
    for k, p in enumerate(poses, start=2):
        assert p.position[1] == pytest.approx(0.3 * k, abs=1e-9)


def test_estimator_without_a_majority_is_not_trusted_and_bounds_both():
    poses, session, rec = _run(lambda t, x: [
        ("a.pose", _pose(t, x, 0.0, 0.3)), ("b.pose", _pose(t, x + 6.0, 0.0, 0.3))])
    for p in poses[1:]:     # (the first is a's alone: before the odometry starts)
        assert not p.trusted
        # the protection radius holds each hypothesis' position with its own radius
        for dx in (0.0, 6.0):
            assert p.protection_radius >= abs(p.position[0] - (p.t + dx)) + \
                gaussian_protection_radius(np.eye(2) * 0.09) - 1e-9
    assert "inputs_disagree" in {d.code for d in rec.on("diagnostics")}


def test_estimator_carries_an_old_input_along_the_odometry():
    # b stops reporting after t = 5; until max_age (10 s) it is carried east with the
    # steps, a's wide pose 1.5 m off does not pull it
    def poses(t, x):
        out = [("a.pose", _pose(t, x + 1.5, 0.0, 2.0))]
        if t <= 5:
            out.append(("b.pose", _pose(t, x, 0.0, 0.2)))
        return out
    poses_out, _, _ = _run(poses, {"quality": {"enabled": False}})
    at = {p.t: p for p in poses_out}
    assert at[12.0].position[0] == pytest.approx(12.0, abs=0.1)
    assert at[12.0].cov[0, 0] < 0.5
    # beyond max_age b is left out: a's pose and 2 m sigma are all that is left
    assert at[20.0].position[0] == pytest.approx(21.5, abs=1e-6)
    assert at[20.0].cov[0, 0] == pytest.approx(4.0, rel=1e-3)


def test_floor_by_vote_of_the_fused_inputs():
    poses, _, _ = _run(lambda t, x: [
        ("a.pose", _pose(t, x, 0.0, 0.5, floor=1)), ("b.pose", _pose(t, x, 0.0, 0.5, floor=1)),
        ("c.pose", _pose(t, x, 0.0, 1.5, floor=None))])
    assert {p.floor for p in poses} == {1}


def test_an_input_that_only_votes_gives_its_floor_and_nothing_else():
    # a (floor 1) and b (floor 2) at the truth tie on the floor, which then stays at 1 (the
    # lower, first); w (position: false), 6 m north with a tighter covariance than both,
    # votes floor 2: the floor becomes 2 and the pose stays a and b's, unmoved by w
    def inputs(t, x, with_w):
        msgs = [("a.pose", _pose(t, x, 0.0, 0.5, floor=1)),
                ("b.pose", _pose(t, x, 0.0, 0.5, floor=2))]
        return msgs + ([("w.pose", _pose(t, x, 6.0, 0.3, floor=2))] if with_w else [])
    params = {"quality": {"enabled": False}, "inputs": {"w.pose": {"position": False}}}
    without, _, _ = _run(lambda t, x: inputs(t, x, False), params)
    voting, _, _ = _run(lambda t, x: inputs(t, x, True), params)
    assert {p.floor for p in without} == {1}
    assert {p.floor for p in voting[2:]} == {2}
    for p, q in zip(without[1:], voting[2:]):
        np.testing.assert_allclose(p.position, q.position, atol=1e-9)
        np.testing.assert_allclose(p.cov, q.cov, atol=1e-9)


def test_a_step_is_published_again_when_an_input_that_was_not_waited_for_answers():
    # a skips step 3; with wait_for 0 step 4 is not held for it (it did not answer step
    # 3): step 4 is fused with a's pose of step 2 carried, then again with a's pose of 4
    msgs = []
    for k in range(1, 7):
        t = float(k)
        msgs.append(("dr.odometry", _odometry(t, t)))
        if k != 3:
            msgs.append(("a.pose", _pose(t, t, 0.3 * k, 0.5)))
    rec = Session(TeamFusionEstimator, {"propagation": {"wait_for": 0.0}}).run(msgs)
    poses = rec.on("pose")
    assert [p.t for p in poses] == [2.0, 3.0, 4.0, 4.0, 5.0, 6.0]
    # step 3 (at the next step's odometry) and the first step 4: a's pose of 2 carried
    assert poses[1].position[1] == pytest.approx(0.6) and poses[2].position[1] == pytest.approx(0.6)
    assert poses[3].position[1] == pytest.approx(1.2)
    # with the default wait a skipped step still holds the next one for a: once each
    rec = Session(TeamFusionEstimator, {}).run(msgs)
    assert [p.t for p in rec.on("pose")] == [2.0, 3.0, 4.0, 5.0, 6.0]


def test_the_gate_lets_adjacent_floors_agree_and_floors_two_apart_contradict():
    means = np.zeros((3, 2))
    covs = np.array([np.eye(2)] * 3)
    ok = gate_matrix(means, covs, [1, 2, 0], chi2_2dof_quantile(0.999))
    assert ok[0, 1] and ok[0, 2]         # one floor apart: the stairs
    assert not ok[1, 2]                  # two apart: a contradiction


def test_on_the_stairs_a_tight_input_a_floor_ahead_is_fused_not_out_voted():
    # on a flight the methods switch floor at their own moments: the tight input (a tag
    # fix) already names floor 2 while three looser ones, sharing one drift 6 m off,
    # still name floor 1; the fused position is the tight input's, and nothing is left out
    poses, session, _ = _run(lambda t, x: [
        ("ekf.pose", _pose(t, x, 0.0, 0.5, floor=2)),
        ("dr.pose", _pose(t, x + 6.0, 0.0, 8.0, floor=1)),
        ("mm.pose", _pose(t, x + 6.0, 0.3, 2.2, floor=1)),
        ("pf.pose", _pose(t, x + 6.0, -0.3, 2.2, floor=1))], {"quality": {"enabled": False}})
    assert "rejected_inputs" not in session.stats.counts["under_test"]
    for p in poses[4:]:
        assert abs(p.position[0] - p.t) < 0.6 and abs(p.position[1]) < 0.3
