"""Stationary data stays put; synthetic walks with exact truth are reproduced."""
from __future__ import annotations

import math

import numpy as np
import pytest

from firenav_plugins.estimators.zupt_ins import ZuptInsParams, eskf
from firenav_framework.geometry import wrap_angle
from firenav_plugins.estimators.zupt_ins.steps import StepTracker

from .conftest import run_engine
from .synthetic import Stride, add_noise, still, walk


@pytest.mark.parametrize("roll,pitch", [(0.0, 0.0), (0.3, -0.5), (math.pi, 0.2), (0.1, 1.45)])
def test_stationary_stays_put(roll, pitch):
    rec = add_noise(still(60.0, roll=roll, pitch=pitch), np.random.default_rng(7),
                    accel_bias=(0.02, -0.01, 0.03))
    res = run_engine(rec.t, rec.accel, rec.gyro)
    aligned = res.states[:, eskf.O_ALIGNED] > 0
    assert aligned[40], "alignment takes 0.1 s of stillness"
    assert res.states[aligned, eskf.O_ZV].all()
    drift = np.abs(res.states[aligned, eskf.O_POS:eskf.O_POS + 3]).max()
    assert drift < 0.01, drift   # a resting foot stays within a centimetre for a minute
    # roll/pitch from gravity: the body z axis is found within a degree of the truth
    q = res.states[-1, eskf.O_Q:eskf.O_Q + 4]
    tilt = math.acos(1 - 2 * (q[1] ** 2 + q[2] ** 2))
    true_tilt = math.acos(math.cos(roll) * math.cos(pitch))
    assert abs(tilt - true_tilt) < math.radians(1.0)
    # standing still: 'still' odometry once per still_period, nothing else
    kinds = res.events[:, eskf.E_KIND]
    assert (kinds == eskf.EVENT_STILL).all() and 55 <= len(kinds) <= 60


def test_gyro_bias_is_learnt_while_standing_with_zaru():
    bias = np.array([0.004, -0.003, 0.005])   # rad/s, typical of the datasets' IMU
    rec = add_noise(still(30.0), np.random.default_rng(2), gyro_bias=bias)
    plain = run_engine(rec.t, rec.accel, rec.gyro)
    zaru = run_engine(rec.t, rec.accel, rec.gyro,
                      ZuptInsParams(filter={"bias_states": True, "gyro_bias_sigma": 0.01},
                                    zaru={"enabled": True}))
    # without bias states the heading drifts by bias_z * t; ZARU learns the bias
    assert abs(wrap_angle(plain.states[-1, eskf.O_YAW] - 0.005 * (30.0 - 0.1))) < 0.01
    assert abs(zaru.states[-1, eskf.O_YAW]) < 0.02


STAIRS = [Stride((0.7, 0.0, 0.0)), Stride((0.7, 0.0, 0.0), turn=math.radians(45)),
          Stride((0.5, 0.5, 0.0)), Stride((0.3, 0.3, 0.17), turn=math.radians(45)),
          Stride((0.0, 0.3, 0.17)), Stride((0.0, 0.3, 0.17)),
          Stride((0.0, -0.3, -0.17)),                      # back down, walking backwards
          Stride((0.0, 0.4, 0.0), turn=math.radians(-90))]


@pytest.mark.parametrize("noisy", [False, True])
def test_synthetic_walk_reproduced(noisy):
    rec = walk(STAIRS)
    if noisy:
        rec = add_noise(rec, np.random.default_rng(11), gyro_bias=(1e-4, -1e-4, 2e-4))
    res = run_engine(rec.t, rec.accel, rec.gyro)
    steps = res.events[res.events[:, eskf.E_KIND] == eskf.EVENT_STEP]
    assert len(steps) == len(STAIRS)
    # one event per stance, its onset within the detector's margin of the true onset, the
    # event itself step_settle into the stance (these stances last longer)
    assert np.all(np.abs(steps[:, eskf.E_STANCE_T0] - rec.stance_onsets) < 0.05)
    settle = ZuptInsParams().outputs.step_settle
    np.testing.assert_allclose(steps[:, eskf.E_T] - steps[:, eskf.E_STANCE_T0], settle, atol=0.006)
    pos = steps[:, eskf.E_POS:eskf.E_POS + 3]
    err = np.linalg.norm(pos - rec.footprints[1:], axis=1)
    assert err.max() < 0.02, err
    yaw_err = [wrap_angle(a - b) for a, b in zip(steps[:, eskf.E_YAW], rec.headings[1:])]
    assert np.abs(yaw_err).max() < math.radians(0.5)


def test_gait_labels_of_synthetic_walk():
    rec = walk(STAIRS + [Stride((0.2, 0.0, 0.0), rest_pitch=1.4, toe_pitch=0.1),
                         Stride((0.2, 0.0, 0.0), rest_pitch=1.4, toe_pitch=0.1)])
    res = run_engine(rec.t, rec.accel, rec.gyro)
    tracker = StepTracker()
    labels = [tracker.step(ev).motion for ev in res.events
              if ev[eskf.E_KIND] == eskf.EVENT_STEP]
    # the label belongs to the step that ends in the labelled rest: the eighth step ends
    # on the knees (foot tilted 80 degrees)
    assert labels == ["walk", "walk", "walk", "stairs_up", "stairs_up", "stairs_up",
                      "stairs_down_backward", "crawl", "crawl", "crawl"]


def test_step_increments_sum_to_track_and_covariance_is_sane():
    rec = add_noise(walk(STAIRS), np.random.default_rng(5))
    res = run_engine(rec.t, rec.accel, rec.gyro)
    tracker = StepTracker()
    steps = [tracker.step(ev) for ev in res.events]
    total = np.sum([s.delta for s in steps], axis=0)
    np.testing.assert_allclose(total, res.events[-1, eskf.E_POS:eskf.E_POS + 3], atol=1e-12)
    for s in steps:
        assert np.allclose(s.cov, s.cov.T) and np.linalg.eigvalsh(s.cov).min() > -1e-15
    walking = [s for s in steps if s.motion != "still"]
    # an increment's uncertainty is a step's worth, not the accumulated absolute one
    assert walking[-1].cov[0, 0] < walking[-1].cov_abs[0, 0]
    assert all(0 < s.cov[0, 0] < 1e-3 for s in walking)


def test_step_covariance_includes_the_unmodelled_errors():
    """A 1.2 m step lasting 1 s gets (0.05 deg/s * 1 s)^2 more heading variance and (2 %
    of its length)^2 more variance along the step, nothing across it; the lasting drift
    rate adds nothing to an increment (it is no step-to-step error)."""
    from firenav_plugins.estimators.zupt_ins.steps import UnmodelledErrors
    base = np.diag([1e-4, 1e-4, 1e-4, 1e-6])
    delta = np.array([1.2, 0.0, 0.0])
    cov = UnmodelledErrors().inflate(base, delta, 1.0)
    assert cov[3, 3] == pytest.approx(1e-6 + np.radians(0.05) ** 2)
    drifting = UnmodelledErrors(yaw_drift_rate_sigma=np.radians(0.17)).inflate(base, delta, 1.0)
    np.testing.assert_array_equal(drifting, cov)
    assert cov[0, 0] == pytest.approx(1e-4 + (0.02 * 1.2) ** 2)
    assert cov[1, 1] == pytest.approx(1e-4) and cov[0, 1] == 0.0
    rotated = UnmodelledErrors().inflate(base, np.array([0.0, 1.2, 0.0]), 1.0)
    assert rotated[1, 1] == pytest.approx(cov[0, 0]) and rotated[0, 0] == pytest.approx(1e-4)
