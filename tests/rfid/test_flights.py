"""Height from the building's stair flights (height.py, flight_tracker.py), and the tag
read that puts a missed flight right.

stair01 of the three-storey plan climbs from floor 0 (0 m) to floor 1 (3.5 m) in 20
stairs: flight 0 north along x = 1.4 m (y 8.0 -> 12.6), a landing at 1.75 m, flight 1
south along x = 4.1 m (y 12.6 -> 8.0). Each flight is 10 stairs of 0.175 m, treads of
0.46 m.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from firenav_framework import TagDetection
from firenav_framework.building import bundled_plan, load_building
from firenav_framework.testing import make_component
from firenav_plugins.estimators.pdr_ekf import PdrEkfEstimator
from firenav_plugins.estimators.pdr_ekf.flight_tracker import FlightTracker
from firenav_plugins.estimators.pdr_ekf.height import StairFlights, stair_flights

from .synth import feed, join, odometry, walk


@pytest.fixture(scope="module")
def building():
    return load_building(bundled_plan("three_storey"))


@pytest.fixture
def tracker(building):
    return FlightTracker(StairFlights(building, zone=3.0))


def drive(tracker, strides, z0: float = 0.0):
    """Feed (gait, INS dz, end xy) strides walked from the first xy; returns the heights
    after each stride and the flights ended ('complete'/'left')."""
    xy, z = np.asarray(strides[0][2], float), z0
    heights, ended = [], []
    for gait, dz, end in strides[1:]:
        end = np.asarray(end, float)
        step = tracker.stride(gait, dz, end - xy, end, z)
        xy, z = end, step.z
        heights.append(z)
        if step.ended:
            ended.append(step.ended)
    return heights, ended


def legs(gait, dzs, a, b):
    """Strides of class ``gait`` with INS rises ``dzs`` from ``a`` to ``b`` (2,)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    n = len(dzs)
    return [(gait, dz, a + (b - a) * (k + 1) / n) for k, dz in enumerate(dzs)]


def test_a_u_shaped_stair_is_two_flights_and_a_landing(building):
    f0, f1 = stair_flights(building.stairs[0])
    assert (f0.z_lo, f0.z_hi, f0.steps) == (0.0, 1.75, 10)
    assert (f1.z_lo, f1.z_hi, f1.steps) == (1.75, 3.5, 10)
    np.testing.assert_allclose(f0.path, [[1.4, 8.0], [1.4, 12.6]])
    np.testing.assert_allclose(f1.path, [[4.1, 12.6], [4.1, 8.0]])
    assert f0.tread == pytest.approx(0.46) and f1.step_rise == pytest.approx(0.175)


def test_a_stair_walked_end_to_end_rises_by_exactly_its_height(tracker):
    """Two strides of each flight under-read by the INS (0.15 m and even a level one
    instead of 0.35 m), one over-read: the height is still exactly the landing, then
    exactly floor 1, because a flight walked from end to end rises by its rise."""
    strides = ([("FW", 0.0, (1.4, 6.9))]
               + legs("FW", [0.0], (1.4, 6.9), (1.4, 8.0))
               + legs("SC", [0.30, 0.15], (1.4, 8.0), (1.4, 9.84))
               + [("FW", 0.02, (1.4, 10.76))]           # the INS saw no stairs here
               + legs("SC", [0.50, 0.33], (1.4, 10.76), (1.4, 12.6))
               + legs("FW", [0.0, 0.0, 0.0], (1.4, 12.6), (4.1, 12.6))     # landing
               + legs("SC", [0.35, 0.15, 0.35, 0.40, 0.30], (4.1, 12.6), (4.1, 8.0))
               + legs("FW", [0.0, 0.0], (4.1, 8.0), (4.9, 6.75)))
    heights, ended = drive(tracker, strides)
    assert ended == ["complete", "complete"]
    assert heights[6] == 1.75                    # on the landing
    assert heights[-1] == 3.5 and heights[-2] == 3.5
    assert all(b >= a for a, b in zip(heights, heights[1:]))     # never down on the way up


def test_backward_descent_and_the_way_back_down(tracker):
    strides = ([("FW", 0.0, (4.1, 8.0))]
               + legs("SDB", [-0.3, -0.35, -0.2, -0.4, -0.35], (4.1, 8.0), (4.1, 12.6))
               + legs("FW", [0.0, 0.0, 0.0], (4.1, 12.6), (1.4, 12.6))
               + legs("SDB", [-0.35, -0.3, -0.3, -0.35, -0.35], (1.4, 12.6), (1.4, 8.0))
               + legs("FW", [0.0], (1.4, 8.0), (1.4, 6.9)))
    heights, ended = drive(tracker, strides, z0=3.5)
    assert ended == ["complete", "complete"]
    assert heights[5] == 1.75 and heights[-1] == 0.0


def test_turning_back_on_a_flight_returns_to_its_entry_level(tracker):
    """Two stairs-up strides, then the firefighter turns and walks back down: the flight
    was left, not completed, and the height is the floor it was entered from."""
    strides = ([("FW", 0.0, (1.4, 8.0))]
               + legs("SC", [0.35, 0.35], (1.4, 8.0), (1.4, 9.84))
               + legs("SDF", [-0.35, -0.35], (1.4, 9.84), (1.4, 8.0))
               + legs("FW", [0.0], (1.4, 8.0), (1.4, 6.9)))
    heights, ended = drive(tracker, strides)
    assert heights[1] == pytest.approx(0.7)
    assert ended == ["left"] and heights[2:] == [0.0, 0.0, 0.0]


@pytest.mark.parametrize("where", ["landing", "corridor"])
def test_stair_like_strides_off_a_flight_are_level(tracker, where):
    """The INS's rise looks like stairs but the stride goes across the landing (not along
    a flight), or along a corridor far from any stair: no height change."""
    a, b, z = {"landing": ((1.4, 12.6), (4.1, 12.6), 1.75),
               "corridor": ((14.0, 6.75), (20.0, 6.75), 0.0)}[where]
    strides = [("FW", 0.0, a)] + legs("SC", [0.35, 0.4, 0.3], a, b)
    steps = []
    xy = np.asarray(a, float)
    for gait, dz, end in strides[1:]:
        steps.append(tracker.stride(gait, dz, end - xy, end, z))
        xy = end
    assert all(s.vetoed and s.z == z and not s.entered for s in steps)


def test_shuffling_on_a_flight_neither_counts_nor_ends_it(tracker):
    strides = ([("FW", 0.0, (1.4, 8.0))]
               + legs("SC", [0.35, 0.35], (1.4, 8.0), (1.4, 9.84))
               + [("SC", 0.1, (1.45, 9.9))]            # 8 cm: turning on the spot
               + legs("SC", [0.35, 0.35, 0.35], (1.45, 9.9), (1.4, 12.6))
               + legs("FW", [0.0], (1.4, 12.6), (2.5, 12.6)))
    heights, ended = drive(tracker, strides)
    assert heights[2] == heights[1] and ended == ["complete"] and heights[-1] == 1.75


def turned(strides, angle_deg: float):
    """The strides as a heading error of ``angle_deg`` shows them: turned about the
    first one's start."""
    a = math.radians(angle_deg)
    R = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    o = np.asarray(strides[0][2], float)
    return [(g, dz, o + R @ (np.asarray(p, float) - o)) for g, dz, p in strides]


def test_a_run_follows_its_own_direction_not_the_estimated_heading(tracker):
    """Down flight 1 with a heading error of 50 deg growing to 75 deg (a foot INS in the
    turns of a stairwell): the flight is entered (50 deg from its axis) and followed to
    its end, since the strides keep their own direction."""
    first = turned([("FW", 0.0, (4.1, 8.0))] + legs("SDB", [-0.35], (4.1, 8.0), (4.1, 8.92)), 50)
    rest = turned([("FW", 0.0, first[-1][2])]
                  + legs("SDB", [-0.35] * 4, first[-1][2], first[-1][2] + (0.0, 3.68)), 75)
    heights, ended = drive(tracker, first + rest[1:] + [("FW", 0.0, rest[-1][2] + (-1.5, 0))],
                           z0=3.5)
    assert ended == ["complete"] and heights[-1] == 1.75


def test_a_stride_the_gait_calls_level_continues_a_run_by_its_rise(tracker):
    """Three strides in a row that the INS sees only 0.11 m down (the gait classifier
    calls them level): on a flight that is still a third of a stair each, and the
    flight is completed."""
    strides = ([("FW", 0.0, (4.1, 8.0))]
               + legs("SDF", [-0.3], (4.1, 8.0), (4.1, 8.92))
               + legs("FW", [-0.11, -0.11, -0.12], (4.1, 8.92), (4.1, 11.68))
               + legs("SDF", [-0.26], (4.1, 11.68), (4.1, 12.6))
               + legs("FW", [0.0], (4.1, 12.6), (2.9, 12.6)))
    heights, ended = drive(tracker, strides, z0=3.5)
    assert ended == ["complete"] and heights[-1] == 1.75


def test_from_a_landing_the_next_flight_whatever_the_heading(tracker):
    """Down flight 1 to the landing, across it with the small false climb the INS
    often shows after a descent (not back up: that needs the geometry), then down
    flight 0 with the heading 80 deg off (the estimate walks west, not south): a
    landing has no other way on down."""
    down1 = ([("FW", 0.0, (4.1, 8.0))]
             + legs("SDB", [-0.35] * 5, (4.1, 8.0), (4.1, 12.6))
             + legs("SC", [0.12, 0.14], (4.1, 12.6), (1.4, 12.6)))
    down0 = turned([("FW", 0.0, (1.4, 12.6))]
                   + legs("SDB", [-0.3] * 5, (1.4, 12.6), (1.4, 8.0))
                   + legs("FW", [0.0], (1.4, 8.0), (2.5, 7.9)), -80)
    heights, ended = drive(tracker, down1 + down0[1:], z0=3.5)
    assert ended == ["complete", "complete"] and heights[-1] == 0.0
    assert heights[5:7] == [1.75, 1.75]


def test_a_stair_end_tag_lets_a_lost_estimate_take_the_flight(building):
    """Down stair12's upper flight from floor 2 (7 m), the estimate 4 m east of the
    stairwell and walking east instead of north: no flight there, unless the tag at
    the stair's top was just read; after more than the stair zone walked on from the
    read, a stair stride is level again."""
    lost = [("FW", 0.0, (8.0, 7.0))] + legs("SDB", [-0.3] * 5, (8.0, 7.0), (12.6, 7.0))
    blind = FlightTracker(StairFlights(building, zone=3.0))
    assert drive(blind, lost, z0=7.0)[0] == [7.0] * 5
    told = FlightTracker(StairFlights(building, zone=3.0))
    told.at_stair_end("stair12", 7.0)
    heights, ended = drive(told, lost + [("FW", 0.0, (12.6, 8.5))], z0=7.0)
    assert ended == ["complete"] and heights[-1] == 5.25
    walked_on = FlightTracker(StairFlights(building, zone=3.0))
    walked_on.at_stair_end("stair12", 7.0)
    strides = [("FW", 0.0, (8.0, 3.0))] + legs("FW", [0.0] * 3, (8.0, 3.0), (8.0, 7.0)) + lost[1:]
    assert drive(walked_on, strides, z0=7.0)[0] == [7.0] * 8


def test_a_late_stair_end_read_takes_the_strides_since_onto_the_flight(building):
    """The same lost descent, the tag's read arriving after three strides down (the
    reader closes a pass seconds after the read): those strides are walked again from
    the stair's top, and the flight is completed with the next two."""
    lost = [("FW", 0.0, (8.0, 7.0))] + legs("SDB", [-0.3] * 5, (8.0, 7.0), (12.6, 7.0))
    tracker = FlightTracker(StairFlights(building, zone=3.0))
    xy, z = np.asarray(lost[0][2], float), 7.0
    for k, (_, dz, end) in enumerate(lost[1:4]):      # vetoed: the gait calls them level
        tracker.stride("FW", dz, end - xy, end, z, t=100.0 + k)
        xy = end
    step = tracker.at_stair_end("stair12", 7.0, t=99.5)
    assert step is not None and step.z == pytest.approx(7.0 - 6 * 0.175)
    heights, ended = drive(tracker, lost[3:] + [("FW", 0.0, (12.6, 8.5))], z0=step.z)
    assert ended == ["complete"] and heights[-1] == 5.25
    late = FlightTracker(StairFlights(building, zone=3.0))
    late.stride("FW", -0.3, np.array([0.9, 0.0]), np.array([8.9, 7.0]), 7.0, t=100.0)
    assert late.at_stair_end("stair12", 7.0, t=100.5) is None    # nothing since the read


def test_a_floor_is_no_landing(tracker, building):
    """The top of stair01 is floor 1, where stair12 starts: a different stair, so
    stair-like strides there are checked against the building as anywhere else."""
    flights = StairFlights(building, zone=3.0)
    assert flights.is_landing("stair01", 1.75) and flights.is_landing("stair12", 5.25)
    assert not flights.is_landing("stair01", 3.5) and not flights.is_landing("stair01", 0.0)
    strides = ([("FW", 0.0, (4.1, 12.6))] + legs("SC", [0.35] * 5, (4.1, 12.6), (4.1, 8.0))
               + legs("SC", [0.35, 0.35], (4.1, 8.0), (9.1, 8.0)))   # on along the corridor
    heights, ended = drive(tracker, strides, z0=1.75)
    assert ended == ["complete"] and heights[-2:] == [3.5, 3.5]


# -- the estimator: a flight the INS did not see at all, put right by a stair-end tag ------

STAIR_TOP_TAG = "E2000000A1B2"


def missed_climb(building, **rfid):
    """Up stair01 with an INS that sees no height at all (every stride level), then a
    read of the tag surveyed at the stair's top, then a few level strides."""
    w = join(walk([(4.5, 6.75), (1.4, 6.9), (1.4, 8.0)], stride=1.0),
             walk([(1.4, 8.0), (1.4, 12.6), (4.1, 12.6), (4.1, 8.0)], stride=0.92),
             walk([(4.1, 8.0), (4.1, 7.0), (4.9, 6.75)], stride=0.9))
    top = int(np.flatnonzero(np.all(np.isclose(w.p[:, :2], [4.1, 8.0]), axis=1))[-1])
    odo = odometry(w, yaw=0.4)
    read = TagDetection(t=float(w.t[top]) + 0.3, agent="ff1", device="ff1/rfid",
                        tag_id=STAIR_TOP_TAG, reader="ff1/rfid", rssi_dbm=-45.0, reads=4)
    ekf, rec, stats = make_component(PdrEkfEstimator, {
        "start": {"mode": "pose", "position": (4.5, 6.75, 0.0),
                  "heading": math.atan2(0.15, -3.1)}, "door_heading": {"enabled": False},
        "rfid": {"surveyed": {STAIR_TOP_TAG: "stair01/top"}, **rfid}}, building=building)
    ekf.start()
    feed(ekf, [*odo, read])
    return rec.on("pose"), stats.counts["under_test"], read.t


def test_a_tag_a_flight_away_sets_the_height_to_its_level(building):
    poses, counts, t_read = missed_climb(building)
    before = [p for p in poses if p.t < t_read]
    assert all(p.position[2] == 0.0 and p.floor == 0 for p in before)   # the INS missed it
    assert counts["tag_level_relocations"] == 1
    after = [p for p in poses if p.t > t_read + 1.0]
    assert after and all(p.floor == 1 and p.position[2] == pytest.approx(3.5, abs=0.01)
                         for p in after)


def test_without_the_level_reset_one_tag_read_moves_the_height_only_part_way(building):
    """Why the reset: the Gaussian update with the tag's height noise (0.1 m) against a
    height known to centimetres moves it by a fraction of the 3.5 m missed."""
    poses, counts, _ = missed_climb(building, level_gate=None)
    assert "tag_level_relocations" not in counts and counts["tag_updates"] == 1
    assert 0.0 < poses[-1].position[2] < 1.75 and poses[-1].floor == 0
