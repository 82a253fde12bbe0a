"""The paper's reading of correction angles, the update matrix, and the door choice."""
from __future__ import annotations

import math

import numpy as np
import pytest

from firenav_framework.building import Door, Floor
from firenav_plugins.constraints.orca.rules import approach_angle, classify_rotation, line_crossing
from firenav_plugins.constraints.orca.doors import DoorTable, RangeFix
from firenav_framework.geometry import Rigid2D

DEG = math.radians
PAPER = dict(min_rotation=DEG(2), max_rotation=DEG(30), door_angle=DEG(90),
             door_tolerance=DEG(15))


@pytest.mark.parametrize("deg, kind", [
    (0.0, "small"), (1.99, "small"), (2.0, "rotation"), (10.0, "rotation"), (-10.0, "rotation"),
    (30.0, "rotation"), (30.01, "blocked"), (74.9, "blocked"), (75.0, "door"), (90.0, "door"),
    (-90.0, "door"), (105.0, "door"), (105.1, "blocked"), (170.0, "blocked"),
    (float("nan"), "blocked"),
])
def test_paper_thresholds(deg, kind):
    assert classify_rotation(DEG(deg), **PAPER) == kind


def test_approach_angle_and_line_crossing():
    wall = np.array([[0.0, 0.0], [10.0, 0.0]])
    assert math.degrees(approach_angle(np.array([1.0, -math.tan(DEG(10))]), wall)) == \
        pytest.approx(10.0)
    assert math.degrees(approach_angle(np.array([-1.0, -1.0]), wall)) == pytest.approx(45.0)
    assert math.degrees(approach_angle(np.array([0.0, 2.0]), wall)) == pytest.approx(90.0)
    assert line_crossing(np.array([3.0, 1.0]), np.array([0.0, -4.0]), wall) == 0.25
    assert line_crossing(np.array([3.0, 1.0]), np.array([0.0, -0.5]), wall) == 1.0


def test_update_matrix_is_eq_8_and_rotates_about_the_agent():
    u = Rigid2D(DEG(30), np.array([2.0, -1.0]))
    c, s = math.cos(DEG(30)), math.sin(DEG(30))
    np.testing.assert_allclose(u.matrix, [[c, -s, 2.0], [s, c, -1.0], [0, 0, 1]])
    p = np.array([1.5, 4.0, 7.0])
    np.testing.assert_allclose(u.apply(p), [*(u.matrix @ [1.5, 4.0, 1.0])[:2], 7.0])
    pivot = np.array([3.0, 1.0])
    rot = Rigid2D.rotation_about(DEG(10), pivot)
    np.testing.assert_allclose(rot.apply(pivot), pivot, atol=1e-12)
    # composition: 'then' applies the later update after the earlier transform
    both = u.then(rot)
    np.testing.assert_allclose(both.apply(p), rot.apply(u.apply(p)), atol=1e-12)
    np.testing.assert_allclose(both.matrix, rot.matrix @ u.matrix, atol=1e-12)
    m = Rigid2D.mapping(np.array([1.0, 1.0]), 0.3, np.array([5.0, 8.4]), 2.0)
    np.testing.assert_allclose(m.apply(np.array([1.0, 1.0])), [5.0, 8.4])
    assert m.angle == pytest.approx(1.7)


def two_doors_floor(partition: bool = False) -> Floor:
    """A wall along y = 0 with doors A (x = 1.0) and B (x = 2.5), 0.9 m wide, 0.6 m apart;
    ``partition``: a wall at x = 1.75 from y = 0 up to 5 m separates the two doors."""
    walls = [[[-20.0, 0.0], [0.55, 0.0]], [[1.45, 0.0], [2.05, 0.0]], [[2.95, 0.0], [20.0, 0.0]]]
    if partition:
        walls.append([[1.75, 0.0], [1.75, 5.0]])
    doors = [Door("A", 0, np.array([1.0, 0.0]), 0.9, np.array([0.0, -1.0])),
             Door("B", 0, np.array([2.5, 0.0]), 0.9, np.array([0.0, -1.0]))]
    return Floor(index=0, z=0.0, height=3.0, walls=np.array(walls), doors=doors)


def test_door_choice_follows_the_uwb_range_not_the_distance():
    table = DoorTable(two_doors_floor())
    wall = np.array([[-20.0, 0.0], [0.55, 0.0]])
    crossing, step = np.array([0.2, 0.0]), np.array([0.0, -1.3])   # A is nearer
    agent = crossing - 0.5 * step
    anchor = np.array([10.0, 1.0, 1.0])
    assert table.ids[table.choose(agent, crossing, step, wall, [], 1.0, 4.0, 0.3)] == "A"
    true_b = np.hypot(10.0 - 2.5, 1.0)                # the firefighter went through B
    fix = RangeFix(anchor, true_b + 0.05, 0.1)
    k = table.choose(agent, crossing, step, wall, [fix], 1.0, 4.0, 0.3)
    assert table.ids[k] == "B"
    assert table.range_misfit(k, [fix], 1.0) == 0.0
    # a range that fits neither door: the best is still B, but its misfit is reported
    far = RangeFix(anchor, 3.0, 0.1)
    assert table.range_misfit(table.choose(agent, crossing, step, wall, [far], 1.0, 4.0, 0.3),
                              [far], 1.0) == pytest.approx(np.hypot(7.5, 1.0) - 3.0 - 0.3)


def test_door_candidates_lie_in_the_hit_wall_ahead_and_near():
    table = DoorTable(two_doors_floor())
    wall = np.array([[2.95, 0.0], [20.0, 0.0]])
    step = np.array([0.0, -1.3])
    far = np.array([9.0, 0.0])
    assert table.choose(far + [0, 0.6], far, step, wall, [], 1.0, 4.0, 0.3) is None  # too far
    # walking away from the wall (doors behind): none
    assert table.choose(np.array([2.0, 1.0]), np.array([2.0, 2.0]), -step, wall, [], 1.0, 4.0,
                        0.3) is None
    # a wall not in line with any door: none
    other = np.array([[0.0, 5.0], [0.0, -5.0]])
    assert table.choose(np.array([0.6, 0.5]), np.array([0.0, 0.5]), np.array([-1.3, 0.0]),
                        other, [], 1.0, 4.0, 0.3) is None


def test_a_door_beyond_a_partition_is_not_a_candidate():
    """The agent (east of a partition) runs into the wall next to door B; door A is as
    near and fits the range better, but lies on the other side of the partition."""
    anchor = np.array([1.0, 3.0, 1.0])
    fix = RangeFix(anchor, float(np.hypot(3.0, 0.0)), 0.1)      # exactly door A's range
    wall = np.array([[1.45, 0.0], [2.05, 0.0]])
    agent, crossing, step = np.array([1.9, 0.6]), np.array([1.9, 0.0]), np.array([0.0, -1.2])
    for partition, expect in ((False, "A"), (True, "B")):
        table = DoorTable(two_doors_floor(partition))
        assert table.ids[table.choose(agent, crossing, step, wall, [fix], 1.0, 4.0, 0.3)] == expect
