"""Every bundled scenario runs, is deterministic, and its people move like people."""
from __future__ import annotations

import numpy as np
import pytest

from firenav_framework.simulator import bundled_scenarios, load_scenario, simulate
from firenav_framework.simulator.gaits import KNEEL_PITCH
from firenav_framework.simulator.imu_ideal import device_matrix, ideal_imu

#: The reference scenarios the issue asks for (the demo and the real-data twin on top).
REFERENCE = ["search_flat_right", "search_flat_left", "search_area250", "breadcrumb_loop",
             "breadcrumb_fire", "orca_test1", "orca_test2", "orca_test3", "zupt_multifloor",
             "rfid_route"]
CAP = {"breadcrumb_fire": 240.0}   # its radio world is the slow part; the plan is planned whole


@pytest.fixture(scope="module")
def runs():
    return {name: simulate(name, 1, duration_s=CAP.get(name)) for name in bundled_scenarios()}


def test_every_reference_scenario_is_bundled_and_runs(runs):
    assert set(REFERENCE) <= set(bundled_scenarios())
    for name, r in runs.items():
        assert r.t_end > 30, name
        for agent, tr in r.truth.items():
            assert tr.distance_m > 20, (name, agent)
            rec = r.imu[agent]
            on = rec.time[0] - 1.0 / rec.rate_hz          # switched on then (phase aside)
            assert len(rec.time) == pytest.approx((r.t_end - on) * rec.rate_hz, abs=2)
            assert np.all(np.isfinite(rec.accel)) and np.all(np.isfinite(rec.gyro))


def _wall_crossings(building, xyz: np.ndarray) -> int:
    """Moves between consecutive points on one floor level that touch a wall."""
    n = 0
    for f in building.floors:
        on = np.abs(xyz[:, 2] - f.z) < 0.3   # on this floor's level (not on the stairs)
        both = on[:-1] & on[1:]
        if both.any():
            n += int(f.crosses_wall(xyz[:-1][both, :2], xyz[1:][both, :2]).sum())
    return n


def test_paths_never_cross_a_wall(runs):
    """... of the world they walk (in the field family not always of the plan)."""
    for name, r in runs.items():
        for agent, tr in r.truth.items():
            assert _wall_crossings(r.world, tr.position) == 0, (name, agent, "body")
            foot = tr.foot.position.copy()
            foot[:, 2] -= 0.06   # the IMU rides above the floor
            assert _wall_crossings(r.world, foot) == 0, (name, agent, "foot")


def test_same_seed_same_run_other_seed_other_run():
    a, b, c = simulate("demo", 7, duration_s=90), simulate("demo", 7, duration_s=90), \
        simulate("demo", 8, duration_s=90)
    for agent in a.imu:
        assert np.array_equal(a.imu[agent].accel, b.imu[agent].accel)
        assert np.array_equal(a.imu[agent].gyro, b.imu[agent].gyro)
        assert np.array_equal(a.truth[agent].position, b.truth[agent].position)
        assert not np.array_equal(a.imu[agent].gyro, c.imu[agent].gyro)
    for port in a.messages:
        assert [m.digest() for m in a.messages[port]] == [m.digest() for m in b.messages[port]]
    assert a.tags.keys() == b.tags.keys()


def test_stance_in_a_scenario_is_still_and_on_the_floor(runs):
    r = runs["zupt_multifloor"]
    kin = r.truth["ff1"].foot
    assert np.all(kin.velocity[kin.stance] == 0) and np.all(kin.omega_body[kin.stance] == 0)
    levels = np.array([f.z for f in r.building.floors])
    stance_z = kin.position[kin.stance, 2] - 0.06
    steps = np.abs(stance_z[:, None] - levels[None, :]).min(axis=1)
    # every stance is on a floor or on a tread: a whole number of risers above a level
    rise = r.building.stairs[0].step_height
    assert np.allclose(np.round(steps / rise) * rise, steps, atol=1e-6)
    assert set(np.unique(r.truth["ff1"].floor)) == {0, 1, 2}


def test_descending_backwards_faces_up_the_stairs():
    from firenav_framework.simulator.scenario import load_scenario_text
    text = """
building: three_storey
agents:
  - id: a
    start: {position: [8.0, 6.75], floor: 1, heading_deg: 180, time_s: 2}
    plan:
      - stairs: {to_floor: 0, backwards: true}
"""
    r = simulate(load_scenario_text(text), 0)
    tr = r.truth["a"]
    st = tr.strides
    down = np.array([m == "stairs_down_backward" for m in st.motion])
    assert down.sum() >= 8
    travel = np.arctan2(*(st.p1 - st.p0)[down, 1::-1].T)
    facing = st.yaw1[down]
    # facing is opposite to the travel direction (toe-out aside; the landing's U-turn
    # strides excepted)
    off = np.abs(np.angle(np.exp(1j * (facing - travel - np.pi))))
    assert np.mean(off < np.radians(25)) > 0.75
    assert tr.floor[0] == 1 and tr.floor[-1] == 0


def test_kneeling_tilts_the_foot_and_gravity_follows():
    r = simulate("breadcrumb_fire", 2, duration_s=150)
    kin = r.truth["ff2"].foot
    kneel = kin.stance & (np.abs(kin.euler[:, 1] - KNEEL_PITCH) < 1e-9)
    assert kneel.sum() > 100
    f, _ = ideal_imu(kin, gravity=9.81, device=device_matrix("FLU"))
    assert np.allclose(f[kneel, 0], -9.81 * np.sin(KNEEL_PITCH), atol=1e-9)


def test_team_partner_follows_the_leader_with_the_lag(runs):
    r = runs["demo"]
    lead, follow = r.truth["ff1"], r.truth["ff2"]
    lag = load_scenario("demo").model.agents[1].follow.lag_s
    t = lead.t[(lead.t > 30) & (lead.t < r.t_end - 30)]
    behind = np.column_stack([np.interp(t - lag, lead.t, lead.position[:, i]) for i in range(2)])
    here = np.column_stack([np.interp(t, follow.t, follow.position[:, i]) for i in range(2)])
    gap = np.linalg.norm(here - behind, axis=1)
    assert np.median(gap) < 0.5
    assert follow.distance_m == pytest.approx(lead.distance_m, rel=0.05)


def test_walking_speeds_and_gait_variation_are_human(runs):
    r = runs["search_flat_right"]
    tr = r.truth["ff1"]
    walking = np.array([m == "search" for m in tr.motion])
    v = np.linalg.norm(np.gradient(tr.position[:, :2], tr.t, axis=0), axis=1)
    assert 0.2 < np.median(v[walking]) < 0.8          # slow search in smoke: 0.3-0.8 m/s
    fast = runs["orca_test1"].truth["ff1"]
    vf = np.linalg.norm(np.gradient(fast.position[:, :2], fast.t, axis=0), axis=1)
    assert 0.9 < np.percentile(vf[vf > 0.3], 75) < 1.6
    people = [simulate("orca_test1", s, duration_s=20).truth["ff1"].person for s in range(8)]
    strides = {round(p["stride_scale"], 4) for p in people}
    assert len(strides) == 8 and all(0.8 <= s <= 1.2 for s in strides)


def test_checkpoints_are_recorded_where_the_agent_stood(runs):
    r = runs["orca_test1"]
    cps = r.truth["ff1"].checkpoints
    assert [c.name for c in cps] == [f"P{i}" for i in range(11)]
    xs = [12.27, 20.90, 25.90, 31.60, 35.85]
    assert np.allclose([c.position[0] for c in cps[1:6]], xs, atol=0.05)
    assert np.allclose([c.position[1] for c in cps], 8.40, atol=0.05)
    tr = r.truth["ff1"]
    for c in cps:   # the body really stands there during the stop
        m = (tr.t > c.t_start + 0.5) & (tr.t < c.t_end - 0.5)
        assert np.abs(tr.position[m, :2] - c.position[:2]).max() < 0.02


def test_compartmental_search_enters_rooms_behind_rooms_and_comes_back():
    from firenav_framework.simulator.scenario import load_scenario_text
    text = """
building: area_250
agents:
  - id: a
    start: {entrance: west, time_s: 2}
    plan:
      - walk: {to: [3.0, 5.5]}
      - compartmental_search: {hand: right, rooms: [corridor, n1, n2, s1]}
"""
    r = simulate(load_scenario_text(text), 0)
    tr = r.truth["a"]
    floor = r.building.floor(0)
    rooms = [floor.rooms[i].id if i >= 0 else None for i in floor.room_of(tr.position[:, :2])]
    visits = [k for i, k in enumerate(rooms) if k and (i == 0 or k != rooms[i - 1])]
    # N2 is only reachable through N1: in through N1, search N2, back out through N1
    i2 = visits.index("n2")
    assert visits[i2 - 1] == "n1" and visits[i2 + 1] == "n1"
    assert {"corridor", "n1", "n2", "s1"} <= set(visits)
    assert not {"s2", "n3"} & set(visits)            # outside the allowed rooms
    assert _wall_crossings(r.building, tr.position) == 0


def test_magnetometer_reads_the_earth_field_in_the_device_frame_plus_indoor_disturbance():
    from firenav_framework.simulator.imu_errors import earth_field_enu
    from firenav_framework.simulator.mount import imu_kinematics
    from firenav_framework.simulator.scenario import load_scenario_text
    base = """
building: corridor
environment:
  magnetic: {{intensity_ut: 50, inclination_deg: 65, declination_deg: 0,
             indoor_disturbance_ut: {dist}}}
agents:
  - id: a
    start: {{position: [5.0, 8.4], floor: 0, time_s: 2}}
    sensors:
      imu: {{grade: xsens_mti3, axes: FRD, magnetometer: true,
            mag: {{hard_iron_ut: 0, soft_iron_pct: 0, noise_ut: 0}}}}
    plan:
      - walk: {{via: [[15.0, 8.4], [15.0, 7.6], [5.0, 7.6]]}}
"""
    clean = simulate(load_scenario_text(base.format(dist=0)), 0)
    # the IMU as it sits on the boot (it turns a little on its mount even in stance)
    pose = imu_kinematics(clean.truth["a"].foot, clean.truth["a"].mount)
    bearing = np.radians(clean.building.georef.bearing)
    earth = earth_field_enu(50, 65, 0)
    rot = np.array([[np.cos(bearing), np.sin(bearing)], [-np.sin(bearing), np.cos(bearing)]])
    b_plan = np.array([*(rot.T @ earth[:2]), earth[2]])
    expect = np.einsum("nji,j->ni", pose.c_bn, b_plan) * [1, -1, -1]  # FRD
    assert np.allclose(clean.imu["a"].mag, expect, atol=1e-9)
    noisy = simulate(load_scenario_text(base.format(dist=10)), 0)
    dev = noisy.imu["a"].mag - expect
    assert 4 < np.sqrt(np.mean(dev ** 2)) < 20          # ~10 uT rms per axis
    # in the building frame the disturbance is a field over space: smooth, not noise;
    # in stance the IMU moves by millimetres only, so the field it reads barely changes
    dev_n = np.einsum("nij,nj->ni", pose.c_bn, dev * [1, -1, -1])
    step = np.linalg.norm(np.diff(pose.position, axis=0), axis=1)
    change = np.abs(np.diff(dev_n, axis=0)).max(axis=1)
    assert change.max() < 0.5 + 20 * step.max()
    still = clean.truth["a"].foot.stance[1:] & clean.truth["a"].foot.stance[:-1]
    assert np.all(change[still] <= 60.0 * step[still] + 1e-9)   # gradient < 60 uT/m


def test_scenario_anchors_are_in_the_building_the_pipeline_sees(runs):
    b = runs["demo"].building
    (uwb,) = [a for a in b.anchors if a.id == "uwb_entrance"]
    np.testing.assert_allclose(uwb.position, [0.6, 4.9, 0.3])   # floor 0 at z 0, 0.3 m up
    assert uwb.kind == "uwb" and uwb.floor == 0
