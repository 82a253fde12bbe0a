"""The EKF core: eq. 2 prediction, delayed tag position update, heading update."""
from __future__ import annotations

import math

import numpy as np
import pytest

from firenav_framework.geometry import rot2, wrap_angle
from firenav_plugins.estimators.pdr_ekf.filter import I_DTHETA, I_LAMBDA, I_OMEGA, PdrFilter

DEG = math.pi / 180


def make(x=(1.0, 2.0, 0.0, 1.1, 0.2, 0.0), p=(1.0, 1.0, 0.01, 0.01, 0.05, 0.0)):
    return PdrFilter(np.array(x, float), np.diag(np.array(p, float) ** 2))


def test_prediction_is_eq2():
    """E += lambda s cos(theta + dtheta), N += lambda s sin(theta + dtheta), Z += dZ."""
    f = make()
    s, theta = 3.0, 0.7
    f.predict(s * np.array([math.cos(theta), math.sin(theta)]), 0.35, np.zeros((2, 2)), 0.0,
              0.0, 0.0)
    assert f.x[0] == pytest.approx(1.0 + 1.1 * s * math.cos(theta + 0.2))
    assert f.x[1] == pytest.approx(2.0 + 1.1 * s * math.sin(theta + 0.2))
    assert f.x[2] == pytest.approx(0.35)


def test_prediction_covariance_matches_a_numerical_jacobian():
    f = make(x=(1.0, 2.0, 0.0, 1.1, 0.2, 0.01), p=(1.0, 1.0, 0.01, 0.01, 0.05, 0.003))
    D, dt = np.array([2.0, -1.0]), 1.5
    P0 = f.P.copy()

    def g(x):
        return np.array([*(x[:2] + x[I_LAMBDA] * rot2(x[I_DTHETA]) @ D), x[2], x[3],
                         x[4] + x[5] * dt, x[5]])
    x0 = f.x.copy()
    J = np.column_stack([(g(x0 + e) - g(x0 - e)) / 2e-6 for e in np.eye(6) * 1e-6])
    f.predict(D, 0.0, np.zeros((2, 2)), 0.0, 0.0, 0.0, dt=dt)
    np.testing.assert_allclose(f.x, g(x0), atol=1e-12)
    np.testing.assert_allclose(f.P, J @ P0 @ J.T, rtol=1e-6, atol=1e-10)


def test_a_constant_heading_rate_is_learnt_from_tags():
    """An INS whose heading drifts at a constant 0.3 deg/s (an uncalibrated gyro bias):
    after tags every 20 s along a straight walk the rate state holds it, and the
    prediction to the next tag is right without a tag."""
    rate = 0.3 * DEG
    f = PdrFilter(np.array([0, 0, 0, 1, 0, 0.0]),
                  np.diag([0.01, 0.01, 1e-4, 1e-6, (1 * DEG) ** 2, (0.5 * DEG) ** 2]))
    true_p, true_h, t = np.zeros(2), 0.0, 0.0
    for k in range(60):                        # 1 s steps of 1.3 m, east in truth
        D = 1.3 * np.array([math.cos(-true_h), math.sin(-true_h)])   # MEMS drifts off
        true_p = true_p + np.array([1.3, 0.0])
        true_h += rate
        t += 1.0
        f.predict(D, 0.0, np.eye(2) * 1e-4, 0.0, 0.0, 0.0, dt=1.0)
        if k % 20 == 19 and k < 50:
            f.update_position(np.array([*true_p, 0.0]), np.diag([0.04, 0.04, 0.01]),
                              np.zeros(2), 0.0, np.zeros((2, 2)))
    assert f.x[I_OMEGA] == pytest.approx(rate, rel=0.25)
    assert np.hypot(*(f.x[:2] - true_p)) < 1.0


def test_delayed_tag_update_places_the_past_position_at_the_tag():
    """A tag read a while ago: the current position becomes the tag plus the displacement
    walked since (moved by the current scale and heading), not the tag itself."""
    f = make(p=(30.0, 30.0, 1.0, 1e-4, 1e-4, 0.0))
    D_since = np.array([4.0, 0.0])
    z = np.array([10.0, 5.0, 3.5])
    res = f.update_position(z, np.diag([1e-6, 1e-6, 1e-6]), D_since, 0.35, np.zeros((2, 2)))
    assert res.applied
    expected = z[:2] + 1.1 * rot2(0.2) @ D_since
    np.testing.assert_allclose(f.x[:2], expected, atol=1e-3)
    assert f.x[2] == pytest.approx(3.5 + 0.35, abs=1e-3)


def test_tag_update_also_informs_the_heading_perturbation():
    """With an exact position before the walk, the tag at the end fixes dtheta."""
    true_dtheta = 10 * DEG
    f = PdrFilter(np.array([0, 0, 0, 1, 0, 0.0]), np.diag([1e-6, 1e-6, 1e-6, 1e-8, (30 * DEG) ** 2, 0]))
    D = np.array([10.0, 0.0])
    f.predict(D, 0.0, np.zeros((2, 2)), 0.0, 0.0, 0.0)
    z = np.array([*(rot2(true_dtheta) @ D), 0.0])
    f.update_position(z, np.diag([0.01, 0.01, 0.01]), np.zeros(2), 0.0, np.zeros((2, 2)))
    assert f.x[I_DTHETA] == pytest.approx(true_dtheta, abs=1.5 * DEG)


def test_gate_rejects_or_relocates():
    f = make(p=(0.3, 0.3, 0.1, 0.01, 0.01, 0.0))
    z = np.array([21.0, 2.0, 0.0])       # 20 m away, 60 sigma
    res = f.update_position(z, np.diag([0.25, 0.25, 0.01]), np.zeros(2), 0.0, np.zeros((2, 2)),
                            gate=5.0)
    assert not res.applied and f.x[0] == 1.0
    res = f.update_position(z, np.diag([0.25, 0.25, 0.01]), np.zeros(2), 0.0, np.zeros((2, 2)),
                            gate=5.0, relocate=20 * DEG)
    assert res.applied and res.relocated
    assert f.x[0] == pytest.approx(21.0, abs=0.1)
    assert math.sqrt(f.P[I_DTHETA, I_DTHETA]) > 15 * DEG


def test_heading_update_and_wrap():
    f = make(x=(0, 0, 0, 1, 175 * DEG, 0), p=(1, 1, 1, 0.01, 30 * DEG, 0))
    f.update_heading(-175 * DEG, (1 * DEG) ** 2)     # 10 deg away across the +-180 cut
    assert abs(wrap_angle(f.x[I_DTHETA] - (-175 * DEG))) < 0.5 * DEG
    assert -math.pi < f.x[I_DTHETA] <= math.pi


def test_set_height_is_exact_and_keeps_the_rest():
    f = make()
    P_before = f.P.copy()
    f.set_height(3.5, 0.05 ** 2)
    assert f.x[2] == 3.5 and f.P[2, 2] == pytest.approx(0.0025)
    keep = [0, 1, 3, 4, 5]
    np.testing.assert_array_equal(f.P[np.ix_(keep, keep)], P_before[np.ix_(keep, keep)])


def test_bad_shapes_are_refused():
    with pytest.raises(ValueError, match="state must be"):
        PdrFilter(np.zeros(5), np.eye(5))
