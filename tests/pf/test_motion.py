"""Time update: displacement per particle frame and the configured noise model (§V-B)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from firenav_framework.capabilities import OdometryHistory
from firenav_plugins.estimators.particle_filter.motion import MotionNoise, propagate
from firenav_framework.capabilities import Particles
from firenav_framework.geometry import wrap_angles as wrap_angle
from firenav_plugins.estimators.particle_filter.particles import ParticleSummary


def test_noise_free_move_rotates_and_scales_the_increment():
    yaw = np.array([0.0, math.pi / 2, math.pi, -math.pi / 4])
    p = Particles.create(np.zeros((4, 2)), yaw, scale=np.array([1.0, 1.0, 2.0, 1.0]))
    propagate(p, np.array([1.0, 0.0]), 0.5, MotionNoise(0.0, 0.5, 0.0), np.random.default_rng())
    s = math.sqrt(0.5)
    np.testing.assert_allclose(p.xy, [[1, 0], [0, 1], [-2, 0], [s, -s]], atol=1e-12)
    np.testing.assert_allclose(p.yaw, yaw)


@pytest.mark.parametrize("dt, delta", [(0.5, (0.3, 0.1)), (1.3, (0.8, -0.4)), (0.2, (0.0, 0.0))])
def test_noise_matches_the_paper_model_at_any_update_rate(dt, delta):
    """0.12 m per axis and 2 deg per metre per 0.5 s update, accumulated over dt."""
    n = 200_000
    noise = MotionNoise()  # paper defaults
    p = Particles.create(np.zeros((n, 2)), np.zeros(n))
    propagate(p, np.array(delta), dt, noise, np.random.default_rng(4))
    k = dt / 0.5                                   # paper updates in this interval
    dist = math.hypot(*delta)
    var_pos = k * 0.12 ** 2
    var_yaw = k * (math.radians(2.0) * dist / k) ** 2
    err = p.xy - np.array(delta)
    np.testing.assert_allclose(err.mean(axis=0), 0.0, atol=5 * math.sqrt(var_pos / n))
    np.testing.assert_allclose(err.var(axis=0), var_pos, rtol=0.02)
    if dist:
        assert p.yaw.var() == pytest.approx(var_yaw, rel=0.02)
    else:
        assert np.all(p.yaw == 0.0)


def test_summary_uses_circular_heading_statistics():
    p = Particles.create(np.array([[0.0, 0.0], [2.0, 0.0]]), np.zeros(2))
    heading = np.array([math.pi - 0.1, -math.pi + 0.1])     # both near pi
    s = ParticleSummary.of(p, heading, np.zeros(2))
    assert abs(wrap_angle(s.heading - math.pi)) < 1e-12
    assert s.cov[3, 3] == pytest.approx(0.01)
    assert s.xy == pytest.approx([1.0, 0.0]) and s.cov[0, 0] == pytest.approx(1.0)
    assert s.spread_m2 == pytest.approx(1.0)


def test_history_tail_resamples_by_path_length_and_ignores_pauses():
    h = OdometryHistory(keep_m=100)
    for t, x in enumerate([0, 1, 1, 1, 2, 3, 4, 5]):  # a pause at x = 1
        h.append(float(t), np.array([x, 0.0, 0.0]), 0.0)
    assert h.walked_m == 5.0
    np.testing.assert_allclose(h.tail(2.0, 0.5), [[3, 0], [3.5, 0], [4, 0], [4.5, 0], [5, 0]])
    assert h.tail(6.0, 0.5) is None


def test_walk_offset_is_the_imu_yaw_minus_the_walking_direction():
    h = OdometryHistory()
    offset = math.radians(12)
    pos = np.zeros(3)
    for k in range(40):
        direction = 0.3 * k            # a curving walk
        pos = pos + 0.7 * np.array([math.cos(direction), math.sin(direction), 0.0])
        h.append(float(k), pos, direction + offset)
    assert h.walk_offset(20.0) == pytest.approx(offset, abs=1e-9)


def test_yaw_rate_turns_the_frame_and_the_increment_by_its_middle_rotation():
    rate = np.array([0.0, 0.1, -0.2])                             # rad/s
    p = Particles.create(np.zeros((3, 2)), np.zeros(3), yaw_rate=rate)
    propagate(p, np.array([1.0, 0.0]), 2.0, MotionNoise(0.0, 0.5, 0.0), np.random.default_rng(),
              drift_s=2.0)
    np.testing.assert_allclose(p.yaw, 2.0 * rate)
    np.testing.assert_allclose(p.xy, np.column_stack([np.cos(rate), np.sin(rate)]), atol=1e-12)
    np.testing.assert_allclose(p.take(np.array([2, 1])).yaw_rate, rate[[2, 1]])
