"""The shoe pivoting on the floor on tight turns (``MountConfig.pivot_slide_mm``): the
generated slides against their stated size, and what a zero-velocity update misses."""
from __future__ import annotations

import dataclasses

import numpy as np

from firenav_framework.simulator.gait import foot_kinematics
from firenav_framework.simulator.mount import (FLEX_ENDS, MountConfig, contact_index, imu_kinematics,
                                               mount_motion, pivot_slides)

from .test_foot_contact import G, straight_table

FS = 200.0


def turning_table(strides: int, turn_deg: float):
    """``straight_table`` with the foot turning ``turn_deg`` in every swing."""
    table = straight_table(strides)
    yaw = np.radians(turn_deg) * np.arange(strides + 1)
    return dataclasses.replace(table, yaw0=yaw[:-1], yaw1=yaw[1:])


def _kin(table):
    t = np.arange(0.0, table.t1[-1] + 1.0, 1 / FS)
    return foot_kinematics(table, t)


def test_contacts_are_counted_from_the_first_and_held_in_the_air():
    on = np.array([0, 1, 1, 0, 0, 1, 0, 1, 1], bool)
    assert contact_index(on).tolist() == [-1, 0, 0, 0, 0, 1, 1, 2, 2]


def test_slides_have_the_stated_rms_per_radian_of_turn_and_none_when_walking_straight():
    cfg = MountConfig(pivot_slide_mm=25.0)
    kin = _kin(turning_table(400, 60.0))
    s = pivot_slides(kin, cfg, np.random.default_rng(1))
    cid = contact_index(kin.contact)
    first = np.searchsorted(cid, np.arange(1, cid.max() + 1))
    per_contact = s[first]
    assert np.all(s[:, 2] == 0.0)                       # horizontal
    rms_mm_per_rad = 1000 * np.sqrt(np.mean(np.sum(per_contact ** 2, axis=1))) / np.radians(60)
    assert abs(rms_mm_per_rad - 25.0) < 0.1 * 25.0      # 400 draws: within 10 %
    # constant over a contact and through the swing that follows it
    assert np.all(s[cid == 5] == s[first[4]])
    # the first contact (nothing turned before it) and straight walking: no slide
    assert np.all(s[cid == 0] == 0.0)
    straight = _kin(straight_table(20))
    assert np.all(pivot_slides(straight, cfg, np.random.default_rng(1)) == 0.0)
    assert np.all(pivot_slides(kin, MountConfig(), np.random.default_rng(1)) == 0.0)


def test_the_imu_slides_slowly_while_the_foot_is_still_and_springs_back_in_the_swing():
    table = turning_table(12, 60.0)
    kin = _kin(table)
    quiet = dict(sway_dps=0.0, rocking_deg_per_g=0.0, flex_deg=0.0, shear_mm=0.0)
    rng = lambda: np.random.default_rng(3)  # noqa: E731
    off = mount_motion(kin, FS, MountConfig(**quiet), np.zeros(3), rng(), gravity=G)
    on = mount_motion(kin, FS, MountConfig(pivot_slide_mm=40.0, **quiet), np.zeros(3), rng(),
                      gravity=G)
    slide = pivot_slides(kin, MountConfig(pivot_slide_mm=40.0), rng())
    du = on.u - off.u
    cid = contact_index(kin.contact)
    # over flat stance the IMU moves along its contact's slide as the flex grows
    # (quasi-statically), without turning and with under 0.25 g of acceleration: a
    # zero-velocity detector sees a still foot
    ramp = lambda u: u + FLEX_ENDS * np.sin(2 * np.pi * u) / (2 * np.pi)  # noqa: E731
    for c in range(3, 10):
        flat = np.flatnonzero(kin.stance & (cid == c))
        moved = du[flat[-1], :2] - du[flat[0], :2]
        size = np.linalg.norm(slide[flat[0], :2])
        assert size > 0.0
        expect = ramp(kin.phase[flat[-1]]) - ramp(kin.phase[flat[0]])
        assert 0.1 < expect < 0.9
        along = np.dot(moved, slide[flat[0], :2]) / size ** 2
        assert abs(along - expect) < 0.2 * expect
        assert np.linalg.norm(moved - along * slide[flat[0], :2]) < 0.1 * size * expect
        # centimetres a second, but hardly any acceleration (the detector's evidence)
        assert np.linalg.norm(on.u_ddot[flat] - off.u_ddot[flat], axis=1).max() < 2.5
        assert np.linalg.norm(imu_kinematics(kin, on).velocity[flat], axis=1).max() > 0.01
    np.testing.assert_allclose(on.rho, off.rho)
    # by the next landing it has sprung back
    land = np.flatnonzero(np.diff(kin.contact.astype(int)) == 1) + 1
    assert np.abs(du[land[4:10], :2]).max() < 0.1 * np.abs(slide[:, :2]).max()
