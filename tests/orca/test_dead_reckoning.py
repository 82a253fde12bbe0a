"""dead_reckoning: alignment (eq. 9), integration, covariance, outputs and bad input."""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from firenav_framework import GroundTruth, Odometry
from firenav_framework.building import Building, Entrance, Floor, bundled_plan, load_building
from firenav_framework.capabilities.odometry_correction import StepCorrection
from firenav_framework.geometry import Rigid2D
from firenav_framework.testing import check_plugin, make_component
from firenav_plugins.estimators.dead_reckoning import DeadReckoningEstimator
from tests.contract.known import known

YAW = -2.3     # arbitrary INS-frame yaw


def ins_steps(path: np.ndarray, yaw: float = YAW, t0: float = 0.0, cov=None, scale=1.0):
    """Odometry messages (INS frame turned by -yaw) walking through building points ``path``."""
    c, s = math.cos(-yaw), math.sin(-yaw)
    d = np.diff(path, axis=0) * scale
    out, pos = [], np.zeros(3)
    headings = np.arctan2(d[:, 1], d[:, 0]) - yaw
    prev_h = headings[0]
    cov = np.diag([1e-4, 1e-4, 1e-6, 1e-6]) if cov is None else cov
    for k, (dx, dy) in enumerate(d):
        delta = np.array([c * dx - s * dy, s * dx + c * dy, 0.0])
        pos = pos + delta
        out.append(Odometry(t=t0 + k + 1.0, agent="ff1", device="ff1/imu", t_start=t0 + k,
                            delta=delta, dheading=headings[k] - prev_h, cov=cov,
                            position=pos.copy(), heading=headings[k]))
        prev_h = headings[k]
    return out


POSE = {"start": {"mode": "pose", "position": (5.0, 8.4, 0.0), "heading": 0.0}}
L_PATH = np.array([[5.0, 8.4], [6.0, 8.4], [7.0, 8.4], [8.0, 8.4], [8.0, 9.4], [8.0, 10.4]])


def run(params, msgs, building=None, constraints=()):
    dr, rec, stats = make_component(DeadReckoningEstimator, params, building=building)
    dr.constraints.extend(constraints)
    dr.start()
    for m in msgs:
        dr.handle("odo", m)
    dr.finish()
    return rec, stats.counts.get("under_test", {})


def test_known_entry_pose_maps_the_ins_frame_onto_the_building():
    rec, _ = run(POSE,
                 ins_steps(L_PATH))
    poses = rec.on("pose")
    np.testing.assert_allclose([p.position[:2] for p in poses], L_PATH[1:], atol=1e-12)
    assert poses[-1].heading == pytest.approx(math.pi / 2)
    # the corrected odometry is in the building frame and sums to the track
    odo = rec.on("odometry")
    np.testing.assert_allclose(np.cumsum([o.delta[:2] for o in odo], axis=0) + L_PATH[0],
                               L_PATH[1:], atol=1e-12)


def test_corrected_odometry_passes_the_ins_drift_rate_on():
    """The INS's lasting heading drift-rate spread (``Odometry.yaw_drift_rate_sigma``) is a
    property of the INS: the building-frame odometry dead_reckoning re-publishes carries
    it unchanged, so a consumer downstream reads the one value the INS published."""
    sigma = math.radians(0.17)
    msgs = [replace(m, yaw_drift_rate_sigma=sigma) for m in ins_steps(L_PATH)]
    rec, _ = run(POSE, msgs)
    odo = rec.on("odometry")
    assert len(odo) == len(msgs)
    assert all(o.yaw_drift_rate_sigma == sigma for o in odo)


def test_entrance_alignment_uses_the_buildings_entrance():
    b = load_building(bundled_plan("corridor"))
    ent = b.entrances[0]
    path = ent.position + np.outer(np.arange(4), [math.cos(ent.heading), math.sin(ent.heading)])
    rec, _ = run({}, ins_steps(path), building=b)
    np.testing.assert_allclose([p.position[:2] for p in rec.on("pose")], path[1:], atol=1e-12)
    assert all(p.floor == 0 for p in rec.on("pose"))


def test_first_straight_segment_along_a_known_wall_fixes_the_heading():
    # the entry heading is unknown (None); the first 3 m run along a wall heading 0 rad
    path = np.array([[5.0, 8.4], [6.5, 8.4], [8.0, 8.4], [9.5, 8.4], [9.5, 9.9]])
    rec, _ = run({"start": {"mode": "pose", "position": (5.0, 8.4, 0.0),
                            "first_segment": {"wall_heading": 0.0, "distance": 3.0}}},
                 ins_steps(path))
    np.testing.assert_allclose([p.position[:2] for p in rec.on("pose")], path[1:], atol=1e-9)


def test_first_segment_with_a_wobble_uses_the_chord():
    path = np.array([[0.0, 0.0], [1.0, 0.1], [2.0, -0.1], [3.0, 0.0], [3.0, 1.0]])
    rec, _ = run({"start": {"mode": "pose", "position": (0.0, 0.0, 0.0),
                            "first_segment": {"wall_heading": "0 deg", "distance": 3.0}}},
                 ins_steps(path))
    np.testing.assert_allclose([p.position[:2] for p in rec.on("pose")], path[1:], atol=1e-9)


def test_covariance_grows_with_distance_as_heading_error_propagates():
    """Noise-free steps: only the entry uncertainty remains; sideways variance after a
    straight walk of length D is sigma_p^2 + D^2 sigma_h^2 (small-angle)."""
    path = np.column_stack([np.arange(11.0), np.zeros(11)])
    sp, sh = 0.3, 0.05
    start = {"mode": "pose", "position": (0.0, 0.0, 0.0), "heading": 0.0,
             "sigma_position": sp, "sigma_heading": sh}
    no_drift = {"heading_rate_sigma": 0.0, "scale_sigma": 0.0, "turn_sigma": 0.0}
    rec, _ = run({"start": start, "step_noise": {"heading_sigma": 0.0, "length_sigma": 0.0},
                  "drift": no_drift},
                 ins_steps(path, cov=np.zeros((4, 4))))
    for k, p in enumerate(rec.on("pose"), 1):
        assert p.cov[1, 1] == pytest.approx(sp ** 2 + (k * sh) ** 2)
        assert p.cov[0, 0] == pytest.approx(sp ** 2)
        assert p.cov[3, 3] == pytest.approx(sh ** 2)
    # per-step noise adds on top and accumulates; the floors stand in for what the INS
    # covariance leaves out (here: nothing reported at all)
    rec2, _ = run({"start": start, "step_noise": {"heading_sigma": 0.01, "length_sigma": 0.02},
                   "drift": no_drift},
                  ins_steps(path, cov=np.zeros((4, 4))))
    poses = rec2.on("pose")
    for k, p in enumerate(poses, 1):
        assert p.cov[3, 3] == pytest.approx(sh ** 2 + k * 0.01 ** 2)
        assert p.cov[0, 0] == pytest.approx(sp ** 2 + k * 0.02 ** 2)
    assert poses[-1].cov[1, 1] > sp ** 2 + (10 * sh) ** 2


QUIET = {"step_noise": {"heading_sigma": 0.0, "length_sigma": 0.0}}
EXACT_START = {"mode": "pose", "position": (0.0, 0.0, 0.0), "heading": 0.0,
               "sigma_position": 0.0, "sigma_heading": 0.0}


def test_heading_rate_state_grows_the_sideways_error_with_time_squared():
    """A residual heading rate r turns step j (1 m in 1 s) by j*r: the sideways error after
    k steps is r*k(k-1)/2, so its variance is sigma_r^2 (k(k-1)/2)^2, and the heading's is
    (k sigma_r)^2 - not the random walk a white per-step heading noise gives."""
    path = np.column_stack([np.arange(11.0), np.zeros(11)])
    sr = 0.002
    rec, _ = run({"start": EXACT_START, **QUIET,
                  "drift": {"heading_rate_sigma": sr, "scale_sigma": 0.0, "turn_sigma": 0.0}},
                 ins_steps(path, cov=np.zeros((4, 4))))
    for k, p in enumerate(rec.on("pose"), 1):
        assert p.cov[3, 3] == pytest.approx((k * sr) ** 2)
        assert p.cov[1, 1] == pytest.approx((sr * k * (k - 1) / 2) ** 2, abs=1e-15)
        assert p.cov[0, 0] == pytest.approx(0.0, abs=1e-15)


def test_scale_state_grows_the_along_track_error_with_distance():
    path = np.column_stack([np.arange(11.0), np.zeros(11)])
    ss = 0.03
    rec, _ = run({"start": EXACT_START, **QUIET,
                  "drift": {"heading_rate_sigma": 0.0, "scale_sigma": ss, "turn_sigma": 0.0}},
                 ins_steps(path, cov=np.zeros((4, 4))))
    for k, p in enumerate(rec.on("pose"), 1):
        assert p.cov[0, 0] == pytest.approx((ss * k) ** 2)      # along: scale x distance
        assert p.cov[1, 1] == pytest.approx(0.0, abs=1e-15)


def test_a_turn_adds_heading_noise_in_proportion_to_its_angle():
    st = 0.04
    rec, _ = run({**POSE, **QUIET, "drift": {"heading_rate_sigma": 0.0, "scale_sigma": 0.0,
                                             "turn_sigma": st}},
                 ins_steps(L_PATH, cov=np.zeros((4, 4))))
    h = [p.cov[3, 3] for p in rec.on("pose")]
    sh2 = 0.05 ** 2                       # the default start heading sigma
    assert h[2] == pytest.approx(sh2)     # straight so far
    assert h[3] == pytest.approx(sh2 + (st * math.pi / 2) ** 2)   # the 90 deg corner


def test_odometry_heading_variance_raises_the_rate_state():
    """An INS reporting a heading variance of (0.01 rad)^2 per 1 s step implies a residual
    rate of 0.01 rad/s: the heading sigma then grows linearly, k * 0.01 after k steps."""
    path = np.column_stack([np.arange(11.0), np.zeros(11)])
    cov = np.diag([0.0, 0.0, 0.0, 1e-4])
    rec, _ = run({"start": EXACT_START, **QUIET,
                  "drift": {"heading_rate_sigma": 0.0, "scale_sigma": 0.0, "turn_sigma": 0.0}},
                 ins_steps(path, cov=cov))
    last = rec.on("pose")[-1]
    assert last.cov[3, 3] > (10 * 0.01) ** 2        # at least the linear growth
    assert last.cov[3, 3] > 5 * 10 * 1e-4           # far above the random walk's k sigma^2


def test_protection_radius_and_trusted_follow_the_covariance():
    path = np.column_stack([np.arange(41.0), np.zeros(41)])
    rec, _ = run({"start": EXACT_START, **QUIET,
                  "drift": {"heading_rate_sigma": 0.0, "scale_sigma": 0.03, "turn_sigma": 0.0},
                  "integrity": {"alert_limit": 2.0}},
                 ins_steps(path, cov=np.zeros((4, 4))))
    poses = rec.on("pose")
    for k, p in enumerate(poses, 1):
        # isotropic bound of the largest axis: 0.03 k sigma, 3.035 sigma at 99 %
        assert p.protection_radius == pytest.approx(0.03 * k * math.sqrt(-2 * math.log(0.01)))
        assert p.trusted == (p.protection_radius <= 2.0)
    assert poses[0].trusted and not poses[-1].trusted


class Teleport:
    """A constraint that moves the agent by ``shift`` (2,) [m] at step ``at``; ``keep``
    stores the shift in the update matrix (as anchor_range does, so later steps keep
    it), ``explained`` says a measurement accounts for it."""

    def __init__(self, at: int, shift, jump: bool = False, keep: bool = False,
                 explained: bool = False):
        self.at, self.shift, self.jump, self.n = at, np.asarray(shift, float), jump, 0
        self.keep, self.explained = keep, explained

    def correct(self, step):
        self.n += 1
        if self.n != self.at:
            return None
        return StepCorrection(position=step.proposed + np.array([*self.shift, 0.0]),
                              update=Rigid2D.translation(self.shift) if self.keep else None,
                              jump=self.jump, event="teleport", explained=self.explained)


def test_a_correction_the_odometry_contradicts_is_reported_widened_and_not_trusted():
    path = np.column_stack([np.arange(11.0), np.zeros(11)])
    rec, counts = run({**POSE}, ins_steps(path), constraints=[Teleport(5, (0.0, 4.0))])
    poses = rec.on("pose")
    assert counts["odometry_contradicted"] == 1
    diag = [d for d in rec.on("diagnostics") if d.code == "odometry_contradicted"]
    assert len(diag) == 1 and "4.0 m" in diag[0].text and "(10.0, 12.4)" in diag[0].text
    assert poses[3].trusted and not poses[4].trusted
    assert poses[4].cov[1, 1] >= 16.0 and poses[4].protection_radius > 4.0 * 3.0
    # a small correction within the covariance is no contradiction
    rec, counts = run({**POSE}, ins_steps(path), constraints=[Teleport(5, (0.0, 0.2))])
    assert "odometry_contradicted" not in counts
    assert all(p.trusted for p in rec.on("pose")[:6])


def test_gap_in_odometry_is_bridged_from_absolute_positions():
    msgs = ins_steps(L_PATH)
    rec, counts = run(POSE,
                      msgs[:2] + msgs[3:])
    np.testing.assert_allclose(rec.on("pose")[-1].position[:2], L_PATH[-1], atol=1e-12)
    assert counts["gaps_bridged"] == 1


def test_bad_and_stale_odometry_is_counted_and_skipped():
    msgs = ins_steps(L_PATH)
    bad = Odometry(t=2.5, agent="ff1", t_start=2.0, delta=np.array([np.nan, 0.0, 0.0]),
                   dheading=0.0, cov=np.eye(4), position=np.zeros(3), heading=0.0)
    stale = msgs[1]
    rec, counts = run(POSE,
                      msgs[:2] + [bad, stale] + msgs[2:])
    np.testing.assert_allclose([p.position[:2] for p in rec.on("pose")], L_PATH[1:], atol=1e-12)
    assert counts["bad_odometry"] == 1 and counts["stale_odometry"] == 1
    assert [d.code for d in rec.on("diagnostics")] == ["bad_odometry"]


def test_missing_alignment_inputs_fail_clearly():
    with pytest.raises(ValueError, match="mode 'pose' needs a position"):
        make_component(DeadReckoningEstimator, {"start": {"mode": "pose"}})
    with pytest.raises(ValueError, match="mode 'pose' needs a heading"):
        make_component(DeadReckoningEstimator, {"start": {"mode": "pose", "position": (0, 0, 0)}})
    with pytest.raises(ValueError, match="read only with mode 'pose'"):
        make_component(DeadReckoningEstimator, {"start": {"position": (0, 0, 0), "heading": 0}})
    dr, _, _ = make_component(DeadReckoningEstimator, {})
    with pytest.raises(ValueError, match="needs a building"):
        dr.start()
    b = Building("no_entrance", [Floor(index=0, z=0.0, height=3.0, walls=np.zeros((0, 2, 2)))])
    dr, _, _ = make_component(DeadReckoningEstimator, {"imu_yaw_offset": {"angle": 0.0}}, building=b)
    dr.start()
    with pytest.raises(ValueError, match="no entrance"):
        dr.handle("odo", ins_steps(L_PATH)[0])


def test_conforms_to_the_plugin_contract():
    b = Building("b", [Floor(index=0, z=0.0, height=3.0, walls=np.zeros((0, 2, 2)))],
                 entrances=[Entrance("e", 0, np.array([1.0, 2.0]), 0.5)])
    check_plugin(DeadReckoningEstimator, {}, sample_input=[("odo", m) for m in ins_steps(L_PATH)],
                 building=b, exclude=known("estimator", "dead_reckoning"))


def test_toe_out_between_imu_yaw_and_walking_direction_is_estimated():
    """A boot IMU reads 7 deg of toe-out (its yaw is not the walking direction): aligning
    its yaw with the entry heading would turn the whole track by 7 deg."""
    path = np.column_stack([5.0 + np.arange(8.0), np.full(8, 8.4)])
    msgs = ins_steps(path)
    toe = math.radians(7.0)
    msgs = [replace(m, heading=m.heading + toe) for m in msgs]
    rec, _ = run(POSE, msgs)
    np.testing.assert_allclose([p.position[:2] for p in rec.on("pose")], path[1:], atol=1e-9)
    assert rec.on("pose")[-1].heading == pytest.approx(0.0, abs=1e-9)   # walking direction
    rec, _ = run({**POSE, "imu_yaw_offset": {"angle": 0.0}}, msgs)      # told: no offset
    end = rec.on("pose")[-1].position
    assert math.atan2(end[1] - 8.4, end[0] - 5.0) == pytest.approx(-toe)


def test_truth_alignment_takes_the_true_pose_when_the_ins_starts():
    """'truth': the true position and facing direction when the INS starts (what a
    surveyed start or GNSS at the entrance gives); the IMU's toe-out is estimated."""
    path = np.column_stack([2.0 + np.zeros(9), 3.0 + 1.1 * np.arange(9)])
    path = np.vstack([path, path[-1] + [1.0, 0.0]])
    msgs = [replace(m, heading=m.heading + 0.2) for m in ins_steps(path, t0=10.0)]
    truth = [GroundTruth(t=t, agent="ff1", heading=math.pi / 2 if t <= 10.0 else 0.0,
                         position=np.array([2.0, 3.0, 0.0]) if t <= 10.0 else np.full(3, 50.0))
             for t in np.arange(0.0, 25.0, 0.25)]
    stream = sorted([("truth", g) for g in truth] + [("odo", m) for m in msgs],
                    key=lambda sm: sm[1].t)
    dr, rec, stats = make_component(DeadReckoningEstimator, {"start": {"mode": "truth"}})
    dr.start()
    for name, m in stream:
        dr.handle(name, m)
    dr.finish()
    np.testing.assert_allclose([p.position[:2] for p in rec.on("pose")], path[1:], atol=1e-9)
    # without any ground truth the steps cannot be placed: an error diagnostic, counted
    dr, rec, stats = make_component(DeadReckoningEstimator, {"start": {"mode": "truth"}})
    dr.start()
    for m in msgs:
        dr.handle("odo", m)
    dr.finish()
    assert rec.on("pose") == []
    assert [d.code for d in rec.on("diagnostics")] == ["not_aligned"]
    assert stats.counts["under_test"]["unaligned_steps"] == len(msgs)
