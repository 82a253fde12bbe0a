"""wall_follow: a straight run alongside a wall is turned parallel to it (hand-worked)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from firenav_framework.testing import check_plugin
from firenav_plugins.constraints.wall_follow import WallFollowConstraint
from firenav_plugins.constraints.wall_follow.constraint import wall_alongside
from tests.orca.walker import Walker, building

DEG = math.radians
MAX = DEG(8)
WALL = [[[-50.0, 0.0], [50.0, 0.0]]]


def run_at(deg: float, y0: float = 1.0, length: float = 3.0):
    a = np.array([0.0, y0])
    return a, a + length * np.array([math.cos(DEG(deg)), math.sin(DEG(deg))])


@pytest.mark.parametrize("wall", [[[-10.0, 0.0], [10.0, 0.0]], [[10.0, 0.0], [-10.0, 0.0]]])
def test_signed_angle_and_distance_do_not_depend_on_the_walls_direction(wall):
    a, b = run_at(3.0)
    ang, dist = wall_alongside(a, b, np.array([wall]), 2.0, MAX)
    assert ang == pytest.approx(DEG(3.0))
    assert dist == pytest.approx(1.0 + 1.5 * math.sin(DEG(3.0)))


def test_which_wall_a_run_follows():
    two = np.array([[[-10.0, 0.0], [10.0, 0.0]], [[-10.0, 3.0], [10.0, 3.0]]])
    a, b = run_at(-2.0, y0=2.2)
    ang, dist = wall_alongside(a, b, two, 2.0, MAX)           # the nearer wall, y = 3
    assert ang == pytest.approx(DEG(-2.0))
    assert dist == pytest.approx(0.8 + 1.5 * math.sin(DEG(2.0)))
    walls = two[:1]
    assert wall_alongside(*run_at(10.0), walls, 2.0, MAX) is None          # too steep
    assert wall_alongside(*run_at(1.0, y0=2.5), walls, 2.0, MAX) is None   # too far
    a = np.array([0.0, 0.1])
    assert wall_alongside(a, np.array([3.0, -0.1]), walls, 2.0, MAX) is None   # crosses it
    short = np.array([[[-10.0, 0.0], [0.5, 0.0]]])       # ends before the run's middle half
    assert wall_alongside(*run_at(1.0), short, 2.0, MAX) is None
    assert wall_alongside(a, a, walls, 2.0, MAX) is None                    # no run


def walker(heading: float, y0: float = 1.0, **params) -> Walker:
    return Walker(building(WALL), (0.0, y0), heading,
                  extra=[(WallFollowConstraint, params)])


def test_drift_away_from_the_wall_is_turned_parallel_about_the_runs_middle():
    """The INS heading is 2 deg off, away from the wall 1 m to the right. The run starts
    after the first step; after four steps (3.9 m, at least follow_distance) the run is
    rotated -2 deg about its middle (pivot 0.5): the agent keeps half the sideways
    drift, and every later step runs along the wall."""
    a = DEG(2.0)
    w = walker(a)
    step = 1.3 * np.array([math.cos(a), math.sin(a)])
    ends = [w.step(*step) for _ in range(7)]
    assert w.counts() == {"wall_follow": 1}
    p1 = np.array([0.0, 1.0]) + step
    p4 = np.array([0.0, 1.0]) + 4 * step
    np.testing.assert_allclose(ends[2][:2], p1 + 2 * step, atol=1e-12)   # untouched so far
    mid = 0.5 * (p1 + p4)
    expect4 = mid + [1.95, 0.0]
    np.testing.assert_allclose(ends[3][:2], expect4, atol=1e-9)
    for k in (4, 5, 6):
        np.testing.assert_allclose(ends[k][:2], expect4 + [(k - 3) * 1.3, 0.0], atol=1e-9)
    assert w.rec.on("pose")[-1].heading == pytest.approx(0.0, abs=1e-12)


def test_pivot_zero_keeps_the_agent_and_turns_only_later_steps():
    a = DEG(-3.0)                                  # drifting towards the wall 1.5 m away
    w = walker(a, y0=1.5, pivot=0.0)
    step = 1.3 * np.array([math.cos(a), math.sin(a)])
    ends = [w.step(*step) for _ in range(5)]
    np.testing.assert_allclose(ends[3][:2], np.array([0.0, 1.5]) + 4 * step, atol=1e-9)
    np.testing.assert_allclose(ends[4][:2], ends[3][:2] + [1.3, 0.0], atol=1e-9)


def test_a_deliberate_angle_to_the_wall_is_left_alone():
    a = DEG(20.0)
    w = walker(a, y0=0.5)
    step = 1.3 * np.array([math.cos(a), math.sin(a)])
    for k in range(6):
        end = w.step(*step)
    assert w.counts() == {}
    np.testing.assert_allclose(end[:2], np.array([0.0, 0.5]) + 6 * step, atol=1e-12)


def test_a_turn_starts_the_run_afresh():
    """A heading change of 40 deg at the third step restarts the run there and at the
    fourth (the turn is summed over two steps): the correction comes three steps later
    than without it."""
    a = DEG(2.0)
    step = 1.3 * np.array([math.cos(a), math.sin(a)])
    for turn_at, fires_at in ((None, 3), (2, 6)):
        w = walker(a)
        fired = []
        for k in range(8):
            w.step(*step, turn=DEG(40.0) if k == turn_at else 0.0)
            fired.append(w.counts().get("wall_follow", 0))
        assert fired.index(1) == fires_at


def test_a_long_straight_walk_keeps_a_bounded_run():
    w = walker(0.0, max_distance=6.0)
    for _ in range(60):
        w.step(1.3, 0.0)
    run = w.constraints[0][0].runs["ff1"]
    assert w.counts() == {}
    assert run.length <= 6.0 and len(run.ins) <= 6


def test_it_is_a_conforming_plugin():
    check_plugin(WallFollowConstraint)
