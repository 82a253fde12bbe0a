"""The INS's own poses: a covariance that holds the truth, a protection radius from it and
a trusted flag derived from the radius (issue 15, item 1)."""
from __future__ import annotations

import dataclasses
import math
import sys
from pathlib import Path

import numpy as np
import pytest

from firenav_framework.evaluation.metrics import CHI2_2_95
from firenav_framework.integrity import gaussian_protection_radius
from firenav_framework.testing import run_component
from firenav_plugins.estimators.zupt_ins import ZuptInsEstimator, ZuptInsParams
from firenav_plugins.estimators.zupt_ins.pose_uncertainty import PoseUncertainty
from firenav_plugins.estimators.zupt_ins.steps import Step, UnmodelledErrors

from .test_plugin import blocks

REPO = Path(__file__).resolve().parents[2]


def test_poses_carry_the_radius_of_their_covariance_and_trusted_from_it():
    """Before, the pose output had no radius (inf) and was always 'trusted'."""
    rec = run_component(ZuptInsEstimator, {"outputs": {"state_rate": 10.0}}, blocks())
    for port in ("pose", "state"):
        poses = rec.on(port)
        assert poses
        for p in poses:
            assert math.isfinite(p.protection_radius)
            assert p.protection_radius == pytest.approx(gaussian_protection_radius(p.cov[:2, :2]))
            assert p.trusted == (p.protection_radius <= 3.0)
    radii = [p.protection_radius for p in rec.on("pose")]
    assert radii[-1] > radii[0] >= 0.1 * math.sqrt(-2 * math.log(0.01)) - 1e-9  # the floor
    strict = run_component(ZuptInsEstimator, {"integrity": {"alert_limit": 0.05}}, blocks())
    assert not any(p.trusted for p in strict.on("pose"))


def _straight(n: int, length: float, duration: float) -> list[Step]:
    steps = []
    for k in range(n):
        steps.append(Step(t=(k + 1) * duration, t_start=k * duration,
                          delta=np.array([length, 0.0, 0.0]), dheading=0.0, cov=np.zeros((4, 4)),
                          position=np.array([(k + 1) * length, 0.0, 0.0]), heading=0.0,
                          cov_abs=np.zeros((4, 4)), motion="walk", tilt=0.0, swing_samples=0,
                          correction=np.zeros(3)))
    return steps


def test_a_lasting_drift_and_scale_error_grow_as_a_constant_one_does():
    """N steps of length L and duration d along x: a constant drift rate r turns step k
    by r k d, so the error is L sum_k (cos(r k d) - 1, sin(r k d)): its second moment
    over r ~ N(0, sigma_r^2), by dense numerical integration, and (small angles) the
    linear r L d N (N - 1) / 2 across the track; a constant scale error s puts the
    along-track error at s N L; the floor adds to both."""
    n, length, d = 40, 1.3, 1.1
    sigma_r, sigma_s, floor = math.radians(0.2), 0.03, 0.1
    unc = PoseUncertainty(UnmodelledErrors(yaw_rate_sigma=0.0, length_sigma=0.0,
                                           yaw_drift_rate_sigma=sigma_r), sigma_s, floor)
    for st in _straight(n, length, d):
        cov = unc.step(st)
    r = np.linspace(-8 * sigma_r, 8 * sigma_r, 20001)
    pdf = np.exp(-0.5 * (r / sigma_r) ** 2)
    pdf /= pdf.sum()
    turned = np.outer(r, np.arange(n) * d)
    along = length * (np.cos(turned) - 1).sum(axis=1)
    across = length * np.sin(turned).sum(axis=1)
    assert cov[1, 1] == pytest.approx(pdf @ across ** 2 + floor ** 2, rel=1e-6)
    assert cov[0, 0] == pytest.approx(pdf @ along ** 2 + (sigma_s * n * length) ** 2
                                      + floor ** 2, rel=1e-6)
    assert cov[1, 1] == pytest.approx((sigma_r * length * d * n * (n - 1) / 2) ** 2
                                      + floor ** 2, rel=0.03)
    assert cov[3, 3] == pytest.approx((sigma_r * n * d) ** 2)


def test_a_heading_lost_for_good_spreads_the_error_along_the_track_too():
    """Ten minutes at 0.17 deg/s: a heading sigma of 100 deg. Linearised, the error of a
    straight 300 m walk would lie across the track only (a thin ellipse: what the
    ten-minute run's ellipse missed, 43 % held); turned by the whole spread of
    headings it is about as large along the track, and the cross-track variance is
    below the linear one (a sine does not grow past 1)."""
    n, length, d = 300, 1.0, 2.0
    sigma_r = math.radians(0.17)
    unc = PoseUncertainty(UnmodelledErrors(yaw_rate_sigma=0.0, length_sigma=0.0,
                                           yaw_drift_rate_sigma=sigma_r), 0.0, 0.0)
    for st in _straight(n, length, d):
        cov = unc.step(st)
    linear = (sigma_r * length * d * n * (n - 1) / 2) ** 2
    assert cov[1, 1] < 0.5 * linear
    assert 0.3 < cov[0, 0] / cov[1, 1] < 3.0


def test_the_odometry_errors_are_the_poses_step_to_step_part():
    """The step-to-step parts come from the odometry's errors, as the increments carry
    them: with no lasting drift and no scale error the pose variance is their sum."""
    steps = _straight(10, 1.0, 1.0)
    unc = PoseUncertainty(UnmodelledErrors(yaw_rate_sigma=0.01, length_sigma=0.02), 0.0, 0.0)
    for st in steps:
        cov = unc.step(st)
    assert cov[3, 3] == pytest.approx(10 * 0.01 ** 2)
    assert cov[0, 0] == pytest.approx(10 * 0.02 ** 2)


def test_yaw_drift_has_one_home_carried_on_the_odometry():
    """One odometry parameter, odometry.yaw_drift_rate_sigma: every odometry message
    carries it (Odometry.yaw_drift_rate_sigma, rad/s), and the increments stay
    step-to-step only (the same covariance whatever the drift); with
    integrity.drift_rate_sigma null the poses' covariance counts the same spread. Before,
    odometry.yaw_drift_sigma went into the increments and integrity.yaw_drift_sigma, of
    the same name, into the poses only."""
    rate = math.radians(0.3)
    with pytest.raises(Exception):
        ZuptInsParams(integrity={"yaw_drift_sigma": rate})
    default = ZuptInsParams().odometry.yaw_drift_rate_sigma
    assert default == pytest.approx(math.radians(0.17))
    runs = {r: run_component(ZuptInsEstimator, {"odometry": {"yaw_drift_rate_sigma": r},
                                                "integrity": {"drift_rate_sigma": None}},
                             blocks()) for r in (0.0, rate)}
    for r, rec in runs.items():
        assert rec.on("odometry") and all(o.yaw_drift_rate_sigma == r for o in rec.on("odometry"))
    for a, b in zip(runs[0.0].on("odometry"), runs[rate].on("odometry")):
        np.testing.assert_array_equal(a.cov, b.cov)
    still, drifting = runs[0.0].on("pose")[-1], runs[rate].on("pose")[-1]
    elapsed = drifting.t - runs[rate].on("odometry")[0].t_start
    assert drifting.cov[3, 3] - still.cov[3, 3] == pytest.approx((rate * elapsed) ** 2, rel=0.05)
    assert drifting.protection_radius > still.protection_radius


def _fields(msg) -> tuple:
    values = (getattr(msg, f.name) for f in dataclasses.fields(msg))
    return tuple(v.tobytes() if isinstance(v, np.ndarray) else v for v in values)


def test_the_poses_own_drift_spread_leaves_the_odometry_byte_identical():
    """integrity.drift_rate_sigma widens the poses only: every odometry message (what
    dead_reckoning, the particle filter, ORCA, GEN and the team fusion read, with its
    yaw_drift_rate_sigma) is the same to the byte as with the odometry's spread, while
    the poses' heading variance grows by (r^2 - r_odo^2) t^2 [rad^2] after t seconds."""
    rate = math.radians(0.5)
    odo = ZuptInsParams().odometry.yaw_drift_rate_sigma
    runs = {r: run_component(ZuptInsEstimator, {"integrity": {"drift_rate_sigma": r}}, blocks())
            for r in (None, rate)}
    a, b = runs[None].on("odometry"), runs[rate].on("odometry")
    assert a and [_fields(m) for m in a] == [_fields(m) for m in b]
    assert all(m.yaw_drift_rate_sigma == odo for m in b)
    elapsed = b[-1].t - b[0].t_start
    wide, own = runs[rate].on("pose")[-1], runs[None].on("pose")[-1]
    assert wide.cov[3, 3] - own.cov[3, 3] == pytest.approx((rate ** 2 - odo ** 2) * elapsed ** 2,
                                                           rel=0.05)


def test_holding_the_peak_and_the_lost_step_term_leave_the_odometry_byte_identical():
    """integrity.hold_peak and integrity.max_speed act on the poses only: every odometry
    message is the same to the byte with them off, and no pose's horizontal covariance
    is smaller with them on."""
    on = run_component(ZuptInsEstimator, {}, blocks())
    off = run_component(ZuptInsEstimator, {"integrity": {"hold_peak": False,
                                                         "max_speed": None}}, blocks())
    a, b = on.on("odometry"), off.on("odometry")
    assert a and [_fields(m) for m in a] == [_fields(m) for m in b]
    for held, plain in zip(on.on("pose"), off.on("pose")):
        assert np.all(np.linalg.eigvalsh(held.cov[:2, :2] - plain.cov[:2, :2]) >= -1e-12)


def _walk_errors(shared_data: Path, params: ZuptInsParams, own_cov_only: bool):
    sys.path.insert(0, str(REPO / "benchmarks"))
    from bench_ins_real_data import walk_integrity
    from firenav_framework.sources.readers.foot_imu_datasets import load_indoor_walk

    return [walk_integrity(params, load_indoor_walk(path), own_cov_only=own_cov_only)
            for path in sorted((shared_data / "indoor-walks").glob("*.mat"))]


def test_on_the_real_walks_the_ellipse_and_the_radius_hold_the_truth(shared_data):
    """The eight indoor walks at their surveyed strides (rigid fit on the first five, as
    the accuracy figures): with the filter's own covariance the 95 % ellipse held the
    truth at 7 % of the strides (and a radius from it would have trusted strides up to
    5 m off); with the unmodelled errors at 89 %, the radius at 96 % (99 % promised),
    and no stride more than 3 m off is trusted."""
    params = ZuptInsParams()
    before = _walk_errors(shared_data, params, own_cov_only=True)
    now = _walk_errors(shared_data, params, own_cov_only=False)

    def held(errs):
        m2 = np.concatenate([e.mahalanobis2 for e in errs])
        return float(np.mean(m2 <= CHI2_2_95))

    assert held(before) < 0.2
    assert held(now) >= 0.85
    err = np.concatenate([e.horizontal for e in now])
    assert np.mean(err <= np.concatenate([e.protection for e in now])) >= 0.95
    assert not np.any(np.concatenate([e.trusted for e in now]) & (err > 3.0))


def test_fast_steps_add_a_lasting_drift_and_long_swings_a_horizontal_error():
    """N straight steps of length L lasting d at speed v = L / d above speed_from v0: the
    fast-gait rate (sigma q) turns step k by q (v - v0) d k, a cross-track error of
    q (v - v0) d L N (N - 1) / 2 as for a constant drift; a step lasting D > long_swing
    D0 adds (k (D - D0) L)^2 on either axis; walking steps (v <= v0, d <= D0) get
    neither. (Small angles: the linear figures within 3 %.)"""
    from firenav_plugins.estimators.zupt_ins.pose_uncertainty import FastGaitErrors
    n, length, d = 20, 2.4, 0.75
    q, v0, k = math.radians(0.5), 2.0, 0.05
    fast = FastGaitErrors(speed_from=v0, speed_drift_sigma=q, long_swing=2.0,
                          long_swing_sigma=k)
    none = UnmodelledErrors(yaw_rate_sigma=0.0, length_sigma=0.0)
    unc = PoseUncertainty(none, 0.0, 0.0, fast)
    for st in _straight(n, length, d):
        cov = unc.step(st)
    rate = q * (length / d - v0)
    assert cov[1, 1] == pytest.approx((rate * d * length * n * (n - 1) / 2) ** 2, rel=0.03)
    assert cov[3, 3] == pytest.approx((rate * d * n) ** 2)
    assert cov[0, 0] < 0.05 * cov[1, 1]                   # along the track: second order
    long = PoseUncertainty(none, 0.0, 0.0, fast).step(_straight(1, 12.0, 5.0)[0])
    assert long[0, 0] == pytest.approx((k * 3.0 * 12.0) ** 2)   # 2.4 m/s: drift from 0 heading
    walking = PoseUncertainty(none, 0.0, 0.0, fast)
    for st in _straight(n, 1.4, 1.1):
        cov = walking.step(st)
    np.testing.assert_allclose(cov, 0.0, atol=1e-15)


@pytest.mark.parametrize("seed", [104, 113, 131])
def test_a_simulated_3_m_s_run_is_not_trusted_while_more_than_3_m_off(seed):
    """The gait set's 3 m/s run (tuning seeds where the poses were trusted 12-19 % of
    the time while more than 3 m off): running drifts the heading several times faster
    than walking (0.5 deg/s rms on the tuning seeds against 0.26 walking) and missed
    zero-velocity updates lengthen a step by up to a third; the covariance now counts
    both (against the covariance without either, nor the poses' own drift spread), so
    no pose more than 3 m off is trusted and the radius holds the error."""
    sys.path.insert(0, str(REPO / "benchmarks"))
    from bench_ins_gaits import record, sim_integrity

    from firenav_framework.evaluation.metrics import integrity_figures

    rec = record("run", seed)
    now = integrity_figures(sim_integrity(ZuptInsParams(), rec))
    no_fast = integrity_figures(sim_integrity(ZuptInsParams(integrity={
        "speed_drift_sigma": 0.0, "long_swing_sigma": 0.0, "drift_rate_sigma": None,
        "hold_peak": False, "max_speed": None}), rec))
    assert no_fast["trusted_off_fraction"] > 0.05          # the failure, without the terms
    assert now["trusted_off_fraction"] <= 0.02
    assert now["protection_containment"] >= 0.95
    assert now["nees_xy"] < no_fast["nees_xy"]
    assert now["trusted_fraction"] > 0.3                   # not distrusted wholesale


def _sim_figures(gait: str, seed: int, integrity: dict | None = None) -> dict:
    sys.path.insert(0, str(REPO / "benchmarks"))
    from bench_ins_gaits import record, sim_integrity

    from firenav_framework.evaluation.metrics import integrity_figures

    params = ZuptInsParams(integrity=integrity or {})
    return integrity_figures(sim_integrity(params, record(gait, seed)))


@pytest.mark.parametrize("gait", ["corridor_run", "stairs"])
def test_a_unit_drifting_fast_is_not_trusted_while_more_than_3_m_off(gait):
    """Tuning seed 101: the simulated unit's heading drifts at 0.66-0.74 deg/s (4 sigma of
    the odometry's 0.17 deg/s), on the field corridor run (one minute at 3 m/s with stops)
    and on the ten minutes over three storeys. Counting the odometry's spread, the poses
    were trusted 2.4-3.1 % of the time while more than 3 m off; with the poses' own
    spread (0.2 deg/s) at most 2 %, and the radius holds the error more often. Trusted
    stays above 3 % of the poses (the first half minute or so of the ten; 4.6 % on the
    three storeys since the radius no longer shrinks without a fix)."""
    before = _sim_figures(gait, 101, {"drift_rate_sigma": None, "hold_peak": False})
    now = _sim_figures(gait, 101)
    assert before["trusted_off_fraction"] > 0.02            # the failure
    assert now["trusted_off_fraction"] <= 0.02
    assert now["protection_containment"] > before["protection_containment"]
    assert now["trusted_fraction"] > 0.03                   # not distrusted wholesale


def test_on_the_ten_minute_field_run_the_ellipse_holds_a_fast_drifting_unit_more_often():
    """field_multifloor_long, tuning seed 109 (the unit drifts at about 2 sigma of the
    odometry's spread): the 95 % ellipse held the truth at 68 % of the poses with the
    odometry's spread, at 80 % or more with the poses' own, and the radius still holds
    the error (99 % promised; 98 % asked of one run)."""
    before = _sim_figures("multifloor_long", 109, {"drift_rate_sigma": None, "hold_peak": False})
    now = _sim_figures("multifloor_long", 109)
    assert before["ellipse95_containment"] < 0.70
    assert now["ellipse95_containment"] >= 0.80
    assert now["protection_containment"] >= 0.98


def _out_and_back(n: int, length: float, duration: float) -> list[Step]:
    """n steps along +x, then n back along -x (positions as the steps give them)."""
    steps = _straight(n, length, duration)
    for k in range(n):
        back = dataclasses.replace(steps[k], t=(n + k + 1) * duration,
                                   t_start=(n + k) * duration,
                                   delta=np.array([-length, 0.0, 0.0]),
                                   position=np.array([(n - k - 1) * length, 0.0, 0.0]))
        steps.append(back)
    return steps


def test_without_a_fix_the_radius_does_not_shrink_on_the_way_back():
    """Out 20 steps and back 20: for a drift rate r the node errors rotate every later
    step by r t, so on the way back they cancel, and the model's cross-track variance
    passes through zero about sqrt(2) of the way out in time (the heading error's
    integral against the velocity); the poses hold the largest horizontal variance so
    far: the radius never decreases and ends at least at the far point's."""
    errors = UnmodelledErrors(yaw_rate_sigma=0.0, length_sigma=0.0,
                              yaw_drift_rate_sigma=math.radians(0.2))
    steps = _out_and_back(20, 1.4, 1.0)
    plain = PoseUncertainty(errors, 0.0, 0.0)
    held = PoseUncertainty(errors, 0.0, 0.0, hold_peak=True)
    radius = lambda c: gaussian_protection_radius(c[:2, :2], 0.99)  # noqa: E731
    r_plain = np.array([radius(plain.step(st)) for st in steps])
    r_held = np.array([radius(held.step(st)) for st in steps])
    assert r_plain[20:].min() < 0.2 * r_plain[19]          # the model's dip on the way back
    assert np.all(np.diff(r_held) >= -1e-9)
    np.testing.assert_allclose(r_held[:20], r_plain[:20])  # on the way out: the same


def test_a_step_faster_than_anyone_runs_counts_its_whole_length_as_error():
    """A step of 12 m in 1 s (the INS lost its stances and integrated unaided): above
    max_speed (5 m/s) its length is unknown, a variance of its squared length on either
    axis; a 3 m/s running step adds nothing."""
    from firenav_plugins.estimators.zupt_ins.pose_uncertainty import FastGaitErrors

    none = UnmodelledErrors(yaw_rate_sigma=0.0, length_sigma=0.0)
    fast = FastGaitErrors(max_speed=5.0)
    lost = PoseUncertainty(none, 0.0, 0.0, fast).step(_straight(1, 12.0, 1.0)[0])
    assert lost[0, 0] == pytest.approx(144.0) and lost[1, 1] == pytest.approx(144.0)
    running = PoseUncertainty(none, 0.0, 0.0, fast).step(_straight(1, 3.0, 1.0)[0])
    np.testing.assert_allclose(running, 0.0, atol=1e-15)
    assert ZuptInsParams().integrity.max_speed == 5.0


def test_on_a_simulated_out_and_back_walk_a_trusted_pose_stays_well_inside_its_radius():
    """Tuning seed 101 of the gait set's walk (28 m out, 26 m back; its unit drifts at
    about 0.5 deg/s): halfway back the poses' radius had fallen from 4.5 m at the far
    end to 2.3 m, under the 3 m alert limit, with the error at 2.2 m (97 % of the
    radius). Holding the peak, no trusted pose's error exceeds 60 % of its radius; the
    ellipse holds the truth no less often and a third of the poses stay trusted."""
    sys.path.insert(0, str(REPO / "benchmarks"))
    from bench_ins_gaits import record, sim_integrity

    from firenav_framework.evaluation.metrics import integrity_figures

    rec = record("walk", 101)

    def worst(params):
        e = sim_integrity(params, rec)
        return float(np.max(np.where(e.trusted, e.horizontal / e.protection, 0.0))), e

    before, e0 = worst(ZuptInsParams(integrity={"hold_peak": False}))
    now, e = worst(ZuptInsParams())
    assert before > 0.9
    assert now < 0.6
    f, f0 = integrity_figures(e), integrity_figures(e0)
    assert f["ellipse95_containment"] >= f0["ellipse95_containment"]
    assert f["trusted_fraction"] > 0.3


def test_the_clip_log_gives_each_step_the_share_of_its_samples_saturated():
    """Ten samples at 0.1 s, the 3rd, 4th and 9th flagged: the step (0.05, 0.55] holds
    five samples, two of them saturated; the next one (0.55, 1.0] five, one saturated;
    a step without samples (a gap) none."""
    from firenav_plugins.estimators.zupt_ins.clipping import ClipLog

    log = ClipLog()
    t = 0.1 * np.arange(1, 11)
    log.add(t[:6], np.isin(np.arange(6), [2, 3]))
    log.add(t[6:], np.isin(np.arange(6, 10), [8]))
    assert log.share(0.05, 0.55) == pytest.approx(2 / 5)
    assert log.share(0.55, 1.0) == pytest.approx(1 / 5)
    assert log.share(1.0, 1.5) == 0.0
    log.add(np.array([1.6, 1.7]), None)                     # unflagged blocks
    assert log.share(1.5, 1.7) == 0.0


def test_the_clip_log_stays_bounded_while_the_foot_stands_an_hour_and_still_counts():
    """An hour at 200 Hz without a step (standing at a door): the log keeps at most
    about two horizons of samples, and the step that ends the wait still counts every
    sample since the last step (one in ten flagged: a share of 0.1)."""
    from firenav_plugins.estimators.zupt_ins.clipping import ClipLog

    log = ClipLog(horizon=10.0)
    rate, block = 200.0, 20
    n = int(3600 * rate)
    for k in range(0, n, block):
        i = np.arange(k, k + block)
        log.add((i + 1) / rate, i % 10 == 0)
        assert len(log._t) <= 10.0 * rate + 2 * block
    assert log.share(0.0, n / rate) == pytest.approx(0.1)
    log.add(np.array([n / rate + 0.005]), np.array([True]))
    assert log.share(n / rate, n / rate + 0.01) == 1.0      # the aggregate was consumed

def test_a_step_with_many_saturated_samples_counts_its_whole_length_as_error():
    """A saturated sample reads less than the foot did, by an amount unknown: a step
    with more than max_clipped (15 %) of its samples saturated is lost, a variance of
    its squared length on either axis (as a step faster than anyone runs); at or below
    the share it adds nothing."""
    from firenav_plugins.estimators.zupt_ins.pose_uncertainty import FastGaitErrors

    none = UnmodelledErrors(yaw_rate_sigma=0.0, length_sigma=0.0)
    fast = FastGaitErrors(max_clipped=0.15)
    step = _straight(1, 2.0, 0.5)[0]
    lost = PoseUncertainty(none, 0.0, 0.0, fast).step(step, clipped=0.2)
    assert lost[0, 0] == pytest.approx(4.0) and lost[1, 1] == pytest.approx(4.0)
    vouched = PoseUncertainty(none, 0.0, 0.0, fast).step(step, clipped=0.15)
    np.testing.assert_allclose(vouched, 0.0, atol=1e-15)
    assert ZuptInsParams().integrity.max_clipped == 0.15


def test_the_plugin_counts_the_samples_the_sensor_flagged_saturated():
    """The same walk, every sample flagged saturated (ImuBlock.flags): the odometry is
    the same to the byte, and each pose's horizontal variance is larger on either axis
    by the squared horizontal lengths of the steps so far (all of them lost; without
    holding the peak the variances add exactly)."""
    plain = blocks()
    flagged = [(port, dataclasses.replace(b, flags=np.ones(len(b.time), np.uint8)))
               for port, b in plain]
    cfg = {"integrity": {"hold_peak": False}}
    a = run_component(ZuptInsEstimator, cfg, plain)
    b = run_component(ZuptInsEstimator, cfg, flagged)
    odo = a.on("odometry")
    assert odo and [_fields(m) for m in odo] == [_fields(m) for m in b.on("odometry")]
    lost = np.cumsum([float(m.delta[:2] @ m.delta[:2]) for m in odo])
    assert lost[-1] > 1.0                                   # the walk's four steps
    for extra, p, q in zip(lost, a.on("pose"), b.on("pose")):
        np.testing.assert_allclose(np.diag(q.cov - p.cov), [extra, extra, 0.0, 0.0],
                                   atol=1e-9)


RUN_4_M_S = """
name: run_4_m_s
description: the gait set's run at 4 m/s (ins_run.yaml, the run gait faster)
building: corridor
gaits:
  run: {speed: 4.0, stride: 2.5}
agents:
  - id: ff1
    start: {position: [2.0, 8.4], floor: 0, heading_deg: 0, time_s: 5}
    sensors:
      imu: {grade: microstrain_3dm_gx5_25, rate_hz: 200, axes: FRD,
            gyro: {turn_on_bias_dps: 0.2}, accel: {noise_density_ug_rthz: 80}}
    plan:
      - walk: {to: [30.0, 8.4], gait: run}
      - walk: {to: [4.0, 8.4], gait: run}
"""


def test_a_run_at_4_m_s_clipping_a_fifth_of_its_samples_is_not_trusted_while_off(tmp_path):
    """Tuning seed 103 of the 3 m/s run sped up to 4 m/s: the +-8 g accelerometer
    (or the gyro) is at full scale on 13 % of the samples (a fifth of each stride's), each step comes out up
    to 45 % short, and the poses were trusted half the time while 3-16 m off (the radius
    under 3 m). Counting a step with more than 15 % of its samples saturated as lost,
    none is trusted while more than 3 m off; the first steps, before the clipping sets
    in, still are."""
    sys.path.insert(0, str(REPO / "benchmarks"))
    from bench_ins_gaits import record, sim_integrity

    from firenav_framework.evaluation.metrics import integrity_figures

    path = tmp_path / "run_4_m_s.yaml"
    path.write_text(RUN_4_M_S)
    rec = record(path, 103)
    assert rec.saturated.mean() > 0.1
    before = integrity_figures(sim_integrity(ZuptInsParams(integrity={"max_clipped": None}),
                                             rec))
    now = integrity_figures(sim_integrity(ZuptInsParams(), rec))
    assert before["trusted_off_fraction"] > 0.3             # the failure
    assert now["trusted_off_fraction"] <= 0.02
    assert now["protection_containment"] > before["protection_containment"]
    assert now["trusted_fraction"] > 0.1                    # the rest and the first steps
