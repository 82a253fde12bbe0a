"""The synthetic foot IMU obeys strapdown physics.

Independent expectations: finite differences of the analytic trajectory, gravity and
Earth rate rotated by hand, and a plain strapdown integrator (written here, not the
project's INS) that must reproduce the path from the noise-free samples.
"""
from __future__ import annotations

import numpy as np
import pytest
from numba import njit

from firenav_framework.simulator.gait import (LEVEL, TOE_ARM, StrideTable, body_rates,
                                              foot_kinematics)
from firenav_framework.simulator.gaits import KNEEL_PITCH
from firenav_framework.simulator.imu_ideal import (EARTH_RATE, axes_matrix, device_matrix,
                                                   ideal_imu)
from firenav_framework.simulator.mount import MountConfig, imu_kinematics, mount_motion
from firenav_framework.simulator.profiles import bump, progress

G = 9.81


def loop_table(strides: int, *, seed: int = 1, stairs: bool = False, t_start: float = 1.0,
               rockers: bool = True) -> StrideTable:
    """A walk that keeps turning (30 deg every third stride), optionally up and down steps;
    the foot rolls over its heel and ball (``rockers``) or lifts off and lands flat."""
    rng = np.random.default_rng(seed)
    L, T, stance = 1.2, 1.1, 0.4
    turns = np.where(np.arange(strides) % 3 == 2, np.radians(30), 0.0)
    yaw = np.concatenate([[0.0], np.cumsum(turns)])
    step = np.column_stack([np.cos(yaw[1:]), np.sin(yaw[1:])]) * L
    xy = np.vstack([[0.0, 0.0], np.cumsum(step, axis=0)])
    z = 0.06 + (0.35 * np.concatenate([[0], np.cumsum(rng.integers(-1, 2, strides))])
                if stairs else np.zeros(strides + 1))
    p = np.column_stack([xy, z])
    t0 = t_start + np.arange(strides) * T
    zz = np.zeros(strides)
    vstyle = np.sign(np.diff(z)).astype(int) % 3 if stairs else np.zeros(strides, int)
    return StrideTable(t0=t0, t1=t0 + T - stance, p0=p[:-1], p1=p[1:], yaw0=yaw[:-1],
                       yaw1=yaw[1:], pitch0=zz, pitch1=zz, roll0=zz, roll1=zz,
                       clearance=np.full(strides, 0.10), toe_off=np.full(strides, 0.8),
                       heel_strike=np.full(strides, 0.35), roll_amp=np.full(strides, 0.07),
                       sway=np.full(strides, 0.02), vstyle=vstyle,
                       impact=np.full(strides, 0.005),
                       toe_rocker=np.full(strides, 0.22 if rockers else 0.0),
                       heel_rocker=np.full(strides, 0.09 if rockers else 0.0))


@pytest.mark.parametrize("fn,a,b", [(progress, 5, 4), (progress, 3, 5), (bump, 3, 7), (bump, 7, 3)])
def test_profiles_match_finite_differences_and_rest_at_both_ends(fn, a, b):
    s = np.linspace(0.0, 1.0, 20001)
    f, d1, d2 = fn(s, a, b)
    h = s[1] - s[0]
    assert np.allclose(np.gradient(f, h)[2:-2], d1[2:-2], atol=1e-5)
    assert np.allclose(np.gradient(d1, h)[2:-2], d2[2:-2], atol=2e-3 * np.abs(d2).max())
    assert f[0] == pytest.approx(0.0, abs=1e-12)
    assert f[-1] == pytest.approx(1.0 if fn is progress else 0.0, abs=1e-9)
    assert np.abs([d1[0], d1[-1], d2[0], d2[-1]]).max() < 1e-9


def test_kinematics_are_the_derivatives_of_the_trajectory():
    table = loop_table(12, stairs=True)
    t = np.linspace(1.0, 14.0, 3001)
    h = 1e-6
    k0, kp, km = (foot_kinematics(table, t + d) for d in (0.0, h, -h))
    assert np.allclose((kp.position - km.position) / (2 * h), k0.velocity, atol=1e-6)
    # jerk jumps where profile segments meet (stance, toe-off, heel strike...): the
    # central difference is off by up to h * jump there
    assert np.allclose((kp.velocity - km.velocity) / (2 * h), k0.acceleration, atol=5e-3)
    euler_rate = (kp.euler - km.euler) / (2 * h)
    assert np.allclose(body_rates(k0.euler, euler_rate), k0.omega_body, atol=1e-5)
    assert np.allclose((kp.omega_body - km.omega_body) / (2 * h), k0.angular_accel, atol=5e-2)
    assert np.abs(k0.angular_accel).max() > 50.0       # the check above is not vacuous


def test_stance_is_truly_still_and_reads_gravity_only():
    table = loop_table(20)
    t = np.arange(0.0, 24.0, 0.005)
    kin = foot_kinematics(table, t)
    assert 0.3 < kin.stance.mean() < 0.6
    assert np.all(kin.velocity[kin.stance] == 0.0)
    assert np.all(kin.omega_body[kin.stance] == 0.0)
    # between two swings the foot does not move at all
    for k in range(len(table) - 1):
        m = (t > table.t1[k]) & (t < table.t0[k + 1])
        assert np.ptp(kin.position[m], axis=0).max() == 0.0
    f, w = ideal_imu(kin, gravity=G)
    assert np.allclose(np.linalg.norm(f[kin.stance], axis=1), G, atol=1e-12)
    assert np.allclose(w[kin.stance], 0.0)
    # moving: the foot really moves (peak sagittal rate of a walking foot is hundreds of deg/s)
    assert 250 < np.degrees(np.abs(w[:, 1]).max()) < 700
    assert np.linalg.norm(kin.velocity, axis=1).max() > 3.0


def test_gravity_is_in_the_body_frame_for_a_tilted_foot():
    """Kneeling: the foot pitches toes-down by KNEEL_PITCH; gravity then lies mostly on x."""
    zz = np.zeros(1)
    table = StrideTable(t0=np.array([1.0]), t1=np.array([2.3]), p0=np.array([[0, 0, 0.06]]),
                        p1=np.array([[0, 0, 0.11]]), yaw0=np.array([0.7]), yaw1=np.array([0.7]),
                        pitch0=zz, pitch1=np.array([KNEEL_PITCH]), roll0=zz, roll1=zz,
                        clearance=zz, toe_off=zz, heel_strike=zz, roll_amp=zz, sway=zz,
                        vstyle=np.array([LEVEL]))
    kin = foot_kinematics(table, np.array([0.5, 3.0]))
    f, w = ideal_imu(kin, gravity=G)
    s, c = np.sin(KNEEL_PITCH), np.cos(KNEEL_PITCH)
    assert np.allclose(f[0], [0, 0, G], atol=1e-12)
    # x (toe) points down-forward: specific force (up) reads -g sin(pitch) on x
    assert np.allclose(f[1], [-G * s, 0.0, G * c], atol=1e-12)
    assert np.allclose(w, 0.0)


def test_earth_rate_and_device_axes():
    zz = np.zeros(1)
    yaw = np.radians(90.0)   # toe pointing north
    table = StrideTable(t0=np.array([5.0]), t1=np.array([6.0]), p0=np.array([[0, 0, 0.06]]),
                        p1=np.array([[1, 0, 0.06]]), yaw0=np.array([yaw]),
                        yaw1=np.array([yaw]), pitch0=zz, pitch1=zz, roll0=zz, roll1=zz,
                        clearance=zz, toe_off=zz, heel_strike=zz, roll_amp=zz, sway=zz,
                        vstyle=np.array([LEVEL]))
    kin = foot_kinematics(table, np.array([1.0]))
    lat = 52.0
    f, w = ideal_imu(kin, gravity=G, latitude_deg=lat)
    om = EARTH_RATE
    # ENU Earth rate (0, cos L, sin L): with the toe north, it is on forward x and up z.
    assert np.allclose(w[0], [om * np.cos(np.radians(lat)), 0.0, om * np.sin(np.radians(lat))],
                       atol=1e-15)
    assert np.allclose(f[0], [0, 0, G])
    # a z-down device (FRD) sees the same vectors with y and z negated
    f2, w2 = ideal_imu(kin, gravity=G, latitude_deg=lat, device=device_matrix("FRD"))
    assert np.allclose(f2[0], f[0] * [1, -1, -1]) and np.allclose(w2[0], w[0] * [1, -1, -1])
    with pytest.raises(ValueError, match="right-handed"):
        axes_matrix("FLD")
    with pytest.raises(ValueError, match="three letters"):
        axes_matrix("XYZ")


@njit(cache=True)
def _strapdown(dt, f, w, reset, v_true, c0, p0, g, w_ie):
    """Reference strapdown in a local-level frame fixed to the Earth: the body rate
    relative to that frame is the gyro minus the Earth rate seen in the body; attitude by
    rotation vector with the two-sample coning term; trapezoidal velocity and position
    with Coriolis removed; velocity set to the true one wherever ``reset`` (the foot
    stands: zero for an IMU rigid on the foot, millimetres per second on a boot)."""
    n = f.shape[0]
    out = np.empty((n, 3))
    c = c0.copy()
    v = v_true[0].copy()
    p = p0.copy()
    out[0] = p
    for k in range(n - 1):
        w0 = w[k] - c.T @ w_ie
        w1 = w[k + 1] - c.T @ w_ie
        phi = (w0 + w1) * 0.5 * dt + np.cross(w0, w1) * dt * dt / 12.0
        ang = np.sqrt(phi @ phi)
        kx = np.array([[0.0, -phi[2], phi[1]], [phi[2], 0.0, -phi[0]], [-phi[1], phi[0], 0.0]])
        if ang > 1e-12:
            d = np.eye(3) + np.sin(ang) / ang * kx + (1.0 - np.cos(ang)) / ang ** 2 * (kx @ kx)
        else:
            d = np.eye(3) + kx
        cn = c @ d
        a0 = c @ f[k] - 2.0 * np.cross(w_ie, v)
        a1 = cn @ f[k + 1] - 2.0 * np.cross(w_ie, v)
        a0[2] -= g
        a1[2] -= g
        vn = v + (a0 + a1) * 0.5 * dt
        p = p + (v + vn) * 0.5 * dt
        v = vn
        c = cn
        if reset[k + 1]:
            v[:] = v_true[k + 1]
        out[k + 1] = p
    return out


def _ins_error(rate: float, minutes: float, earth: bool, impact: bool = False,
               mount: MountConfig | None = None) -> np.ndarray:
    """3D error of the reference strapdown over a stair walk with rockers: the IMU rigid
    on the foot, or on a compliant ``mount``; with or without heel-strike impacts."""
    strides = int(minutes * 60 / 1.1)
    table = loop_table(strides, stairs=True)
    if not impact:
        table.impact = None
    t = np.arange(0.0, table.t1[-1] + 1.0, 1.0 / rate)
    kin = foot_kinematics(table, t)
    motion = None if mount is None else mount_motion(kin, rate, mount, TOE_ARM * [0, 0, 1],
                                                      np.random.default_rng(3), gravity=G)
    imu = imu_kinematics(kin, motion)
    lat = 48.0 if earth else None
    f, w = ideal_imu(kin, gravity=G, latitude_deg=lat, mount=motion)
    w_ie = (EARTH_RATE * np.array([0.0, np.cos(np.radians(lat)), np.sin(np.radians(lat))])
            if earth else np.zeros(3))
    est = _strapdown(1.0 / rate, f, w, kin.stance, imu.velocity, imu.c_bn[0],
                     imu.position[0].copy(), G, w_ie)
    return np.linalg.norm(est - imu.position, axis=1)


def test_noise_free_imu_through_a_correct_ins_reproduces_five_minutes_to_centimetres():
    err = _ins_error(800.0, 5.0, earth=True)
    assert err.max() < 0.03            # 3D, over five minutes of walking up and down steps
    # what is left is the integrator's own O(dt^2) error: halving the rate quadruples it
    e200 = _ins_error(200.0, 2.0, earth=True).max()
    e400 = _ins_error(400.0, 2.0, earth=True).max()
    assert 3.0 < e200 / e400 < 5.0


def test_impacts_and_a_compliant_mount_are_consistent_physics():
    """The heel-strike transient and the IMU ringing, flexing and swaying on its boot are
    hard to integrate at low rates, but they are the motion of one point: the
    integration error still falls as dt^2, down to centimetres at a high rate."""
    mount = MountConfig()
    e = {r: _ins_error(r, 1.0, earth=False, impact=True, mount=mount).max()
         for r in (400.0, 800.0, 1600.0)}
    assert 3.0 < e[400.0] / e[800.0] < 5.0 and 3.0 < e[800.0] / e[1600.0] < 5.0
    assert e[1600.0] < 0.02
