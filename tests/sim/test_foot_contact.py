"""Ground contact is not stillness: heel and toe rockers, and an IMU that moves on its boot.

Independent expectations: rigid-body geometry (the contact point of a rocker does not
move), the free response of a damped oscillator (frequency, logarithmic decrement,
static sag g / w^2), and the foot truth that stays still in flat stance.
"""
from __future__ import annotations

import numpy as np
import pytest

from firenav_framework.simulator import simulate
from firenav_framework.simulator.gait import (IMPACT_S, LEVEL, FootKinematics, StrideTable,
                                              euler_matrix, foot_kinematics)
from firenav_framework.simulator.imu_ideal import ideal_imu
from firenav_framework.simulator.mount import MountConfig, imu_kinematics, mount_motion
from firenav_framework.simulator.scenario import load_scenario_text
from firenav_framework.simulator.signal_stats import quiet_displacement, stance_statistics

G = 9.81


def straight_table(strides: int = 8, *, toe: float = 0.3, heel: float = 0.12,
                   flex: bool = True) -> StrideTable:
    """Strides of 1.3 m along x, 0.9 s from heel-off to foot-flat, 1.15 s apart."""
    n = strides
    p = np.column_stack([1.3 * np.arange(n + 1), np.zeros(n + 1), np.full(n + 1, 0.06)])
    t0 = 1.0 + 1.15 * np.arange(n)
    z = np.zeros(n)
    return StrideTable(t0=t0, t1=t0 + 0.9, p0=p[:-1], p1=p[1:], yaw0=z, yaw1=z, pitch0=z,
                       pitch1=z, roll0=z, roll1=z, clearance=np.full(n, 0.06),
                       toe_off=np.full(n, np.radians(55)), heel_strike=np.full(n, np.radians(20)),
                       roll_amp=np.full(n, np.radians(4)), sway=np.full(n, 0.02),
                       vstyle=np.full(n, LEVEL), impact=np.full(n, 0.0025),
                       toe_rocker=np.full(n, toe), heel_rocker=np.full(n, heel),
                       flex=np.tile([-0.41, 0.76, -0.51], (n, 1)) if flex else None)


def _point(kin: FootKinematics, arm: np.ndarray) -> np.ndarray:
    return kin.position + np.einsum("nij,j->ni", euler_matrix(kin.euler), arm)


def test_the_foot_rolls_about_its_ball_and_heel_and_is_not_still_on_the_ground():
    table = straight_table()
    t = np.arange(0.5, table.t1[-1] + 0.5, 1 / 400)
    kin = foot_kinematics(table, t)
    s_to, s_hs = table.phases()
    k = np.clip(kin.stride, 0, len(table) - 1)
    s = (t - table.t0[k]) / (table.t1[k] - table.t0[k])
    toe_rocker = (kin.stride >= 0) & (s > 0) & (s < s_to[k])
    heel_rocker = (kin.stride >= 0) & (s > s_hs[k] + IMPACT_S / 0.9) & (s < 1)
    assert toe_rocker.sum() > 500 and heel_rocker.sum() > 100
    # the ball stays where it was at heel-off while the heel rises ...
    ball = _point(kin, table.toe_arm)
    ball_at_heel_off = table.p0[k] + table.toe_arm
    assert np.abs(ball[toe_rocker] - ball_at_heel_off[toe_rocker]).max() < 1e-12
    # ... and the heel where it landed, once the heel pad has taken the impact
    heel = _point(kin, table.heel_arm)
    assert np.abs(heel[heel_rocker] - (table.p1[k] + table.heel_arm)[heel_rocker]).max() < 1e-12
    # on the ground but moving: the IMU on its arc, at hundreds of deg/s at the ends
    speed = np.linalg.norm(kin.velocity, axis=1)
    rate = np.degrees(np.linalg.norm(kin.omega_body, axis=1))
    assert speed[toe_rocker].max() > 0.3 and rate[toe_rocker].max() > 150
    assert speed[heel_rocker].max() > 0.2 and rate[heel_rocker].max() > 150
    assert np.all(kin.contact[toe_rocker | heel_rocker]) and not np.any(kin.stance[toe_rocker])
    # the truly still part is what is left of the contact: ~0.25 s of a 1.15 s stride
    assert np.all(kin.velocity[kin.stance] == 0.0) and np.all(kin.omega_body[kin.stance] == 0.0)
    walking = (t > table.t0[1]) & (t < table.t0[-1])
    assert 0.15 < kin.stance[walking].mean() < 0.3 < kin.contact[walking].mean() < 0.7


def _pulse_kinematics(fs: float, seconds: float = 2.0) -> FootKinematics:
    """A foot at rest, shaken upward by a 5 ms, 3 g pulse at t = 0.5 s."""
    t = np.arange(0.0, seconds, 1 / fs)
    kin = FootKinematics.at_rest(t, [0, 0, 0.06], [0, 0, 0])
    kin.acceleration[(t >= 0.5) & (t < 0.505), 2] = 3 * G
    kin.stance[:] = False
    return kin


@pytest.mark.parametrize("hz,zeta", [(18.0, 0.2), (30.0, 0.1)])
def test_the_mount_rings_at_its_natural_frequency_and_damping(hz, zeta):
    fs = 4000.0
    kin = _pulse_kinematics(fs)
    cfg = MountConfig(natural_hz=hz, damping=zeta, rocking_deg_per_g=0, flex_deg=0, sway_dps=0)
    m = mount_motion(kin, fs, cfg, np.zeros(3), np.random.default_rng(0), gravity=G)
    w = 2 * np.pi * hz
    # at rest the IMU sags on its strap by g / w^2
    assert m.u[100, 2] == pytest.approx(-G / w ** 2, rel=1e-9)
    z = m.u[:, 2] + G / w ** 2
    after = kin.t > 0.51
    peaks = np.flatnonzero((z[1:-1] > z[:-2]) & (z[1:-1] >= z[2:]) & after[1:-1]) + 1
    peaks = peaks[z[peaks] > 1e-3 * np.abs(z).max()][:4]
    period = np.diff(kin.t[peaks]).mean()
    wd = w * np.sqrt(1 - zeta ** 2)
    assert period == pytest.approx(2 * np.pi / wd, rel=0.01)
    decrement = np.log(z[peaks[:-1]] / z[peaks[1:]]).mean()
    assert decrement == pytest.approx(2 * np.pi * zeta / np.sqrt(1 - zeta ** 2), rel=0.02)
    # the IMU reads the foot's pulse plus the ringing, and the ringing dies away
    f, _ = ideal_imu(kin, gravity=G, mount=m)
    ring = np.abs(f[:, 2] - G)
    assert ring[(kin.t > 0.52) & (kin.t < 0.6)].max() > 1.0
    assert ring[kin.t > 1.5].max() < 1e-3 * ring.max()


def test_the_boot_flexes_over_a_contact_and_the_imu_turns_while_the_foot_is_still():
    table = straight_table()
    fs = 200.0
    t = np.arange(0.0, table.t1[-1] + 1.0, 1 / fs)
    kin = foot_kinematics(table, t)
    cfg = MountConfig(sway_dps=0.0)
    m = mount_motion(kin, fs, cfg, np.array([0, 0, -0.06]), np.random.default_rng(0), gravity=G)
    # over a contact (heel strike of stride 2 to toe-off of stride 3) the upper turns
    # along the contact's direction, by flex_deg in all, fastest at both ends; in flat
    # stance (no inertial load) the mount follows that quasi-statically
    s_to, s_hs = table.phases()
    dur = table.t1 - table.t0
    t_hs, t_to = table.t0[2] + s_hs[2] * dur[2], table.t0[3] + s_to[3] * dur[3]
    direction = np.array([-0.41, 0.76, -0.51]) / np.linalg.norm([-0.41, 0.76, -0.51])
    flat = kin.stance & (t > t_hs) & (t < t_to)
    u = (t[flat] - t_hs) / (t_to - t_hs)
    expect = np.radians(cfg.flex_deg) * (u + 0.5 * np.sin(2 * np.pi * u) / (2 * np.pi))
    assert np.degrees(np.abs(m.rho[flat] @ direction - expect)).max() < 0.3
    # and springs back over the swing
    i_hs = np.searchsorted(t, table.t0[3] + s_hs[3] * dur[3])
    assert np.degrees(np.linalg.norm(m.rho[i_hs])) < 1.0
    # the foot is still in flat stance, the IMU on it is not: it turns at deg/s and
    # moves at mm/s to cm/s (what a zero-velocity update there throws away)
    imu = imu_kinematics(kin, m)
    still = kin.stance & (t > table.t0[1]) & (t < table.t0[-1])
    rate = np.degrees(np.linalg.norm(imu.omega_body[still], axis=1))
    assert np.all(kin.omega_body[still] == 0.0)
    assert 1.0 < np.median(rate) < 30.0
    assert 0.002 < np.median(np.linalg.norm(imu.velocity[still], axis=1)) < 0.05
    # a rigid mount leaves the foot's motion alone
    rigid = imu_kinematics(kin, None)
    assert np.array_equal(rigid.position, kin.position)
    bare = FootKinematics(t=t, position=kin.position, velocity=kin.velocity,
                          acceleration=kin.acceleration, euler=kin.euler,
                          omega_body=kin.omega_body, stance=kin.stance, stride=kin.stride)
    with pytest.raises(ValueError, match="angular_accel, contact, phase, flex"):
        mount_motion(bare, fs, cfg, np.zeros(3), np.random.default_rng(0))


def test_ideal_foot_model_and_rigid_mount_switch_the_physics_off():
    text = """
building: corridor
foot_model: {model}
agents:
  - id: a
    start: {{position: [2.0, 8.4], floor: 0, time_s: 3}}
    sensors:
      imu: {{grade: tactical, rate_hz: 200, mount: {mount}}}
    plan:
      - walk: {{to: [20.0, 8.4]}}
"""
    real = simulate(load_scenario_text(text.format(model="realistic", mount="{}")), 0)
    ideal = simulate(load_scenario_text(text.format(model="ideal", mount="{}")), 0)
    rigid = simulate(load_scenario_text(text.format(model="realistic", mount="null")), 0)
    assert real.truth["a"].mount is not None and np.all(real.truth["a"].strides.toe_rocker > 0)
    assert ideal.truth["a"].mount is None and np.all(ideal.truth["a"].strides.toe_rocker == 0)
    assert rigid.truth["a"].mount is None and np.all(rigid.truth["a"].strides.heel_rocker > 0)
    # on a rigid mount, a still foot reads gravity only; on a boot it does not
    for r, quiet in ((ideal, True), (rigid, True), (real, False)):
        kin = r.truth["a"].foot
        walking = kin.stance & (kin.t > 4) & (kin.t < r.t_end - 4)
        f, w = ideal_imu(kin, gravity=G, mount=r.truth["a"].mount)
        rate = np.degrees(np.linalg.norm(w[walking], axis=1))
        assert (rate.max() == 0.0) == quiet


def test_stance_statistics_of_a_simulated_walk_and_bad_input():
    text = """
building: corridor
agents:
  - id: a
    start: {position: [2.0, 8.4], floor: 0, time_s: 3}
    sensors: {imu: {grade: microstrain_3dm_gx5_25, rate_hz: 200}}
    plan:
      - walk: {via: [[34.0, 8.4]]}
"""
    r = simulate(load_scenario_text(text), 0)
    rec, tr = r.imu["a"], r.truth["a"]
    st = stance_statistics(rec.time, rec.accel, rec.gyro)
    strides = int(np.sum(tr.strides.motion == "walk"))
    assert strides - 4 <= st.cycles <= strides
    cycle = np.median(np.diff(tr.strides.t0))
    assert st.summary()["cycle_s"] == pytest.approx(cycle, rel=0.05)
    # the quiet part of a cycle is about the truly still stance plus the rocker tails
    still = np.median(tr.strides.t0[1:] - tr.strides.t1[:-1])
    assert still < st.summary()["below_20_s"] < still + 0.2
    moved = quiet_displacement(rec.time, rec.gyro, imu_kinematics(tr.foot, tr.mount).position)
    assert 0.001 < np.median(moved) < 0.02
    with pytest.raises(ValueError, match="accel and gyro"):
        stance_statistics(rec.time, rec.accel[:, :2], rec.gyro)
    with pytest.raises(ValueError, match="positions"):
        quiet_displacement(rec.time, rec.gyro, np.zeros((3, 3)))
