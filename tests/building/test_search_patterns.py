"""Search-pattern extraction (search-pattern paper §IV-C) against hand-worked sequences."""
from __future__ import annotations

import math

import numpy as np
import pytest
import shapely

from firenav_framework.building import bundled_plan, load_building
from firenav_framework.building.search_patterns import extract_search_patterns
from firenav_framework.building.sketch import PlanSketch


def small_plan(rotate_deg: float = 0.0) -> PlanSketch:
    """Main room 5 x 3 m with a free-standing pillar, a side room 2 x 3 m behind a door.

    Main room x 0..5, y 0..3; entrance door in its south wall at x 1..2 (heading
    north); pillar x 2.1..2.9, y 1.1..1.9; side room x 5..7 with a 1 m door in the
    partition at y 1..2. Everything is rotated by ``rotate_deg`` about the origin.
    """
    a = math.radians(rotate_deg)
    rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])

    def r(*pts):
        out = [tuple(rot @ np.asarray(p, float)) for p in pts]
        return out if len(out) > 1 else out[0]

    def box(x0, y0, x1, y1):
        return r((x0, y0), (x1, y0), (x1, y1), (x0, y1))

    sk = PlanSketch("small")
    f = sk.floor(0.0, 3.0)
    f.room("main", box(0, 0, 5, 3)).room("side", box(5, 0, 7, 3))
    f.door("front", r((1.5, 0)), 1.0, r((0, 1)))
    f.door("inner", r((5, 1.5)), 1.0, r((1, 0)))
    f.obstacle("pillar", box(2.1, 1.1, 2.9, 1.9))
    sk.entrance("e", r((1.5, 0)), heading_deg=90 + rotate_deg, door="front")
    return sk


# Worked by hand: nodes sit at the cell centres (x.5, y.5). The right-hand search enters
# at (1.5, 0.5) heading north and turns right; it follows the south wall, goes through
# the partition door into the side room, round it, back out through the same door and
# along the north and west walls home. (4.5, 1.5) and (5.5, 1.5) are walked twice.
RIGHT_HAND = [(1.5, 0.5), (2.5, 0.5), (3.5, 0.5), (4.5, 0.5), (4.5, 1.5), (5.5, 1.5),
              (5.5, 0.5), (6.5, 0.5), (6.5, 1.5), (6.5, 2.5), (5.5, 2.5), (5.5, 1.5),
              (4.5, 1.5), (4.5, 2.5), (3.5, 2.5), (2.5, 2.5), (1.5, 2.5), (0.5, 2.5),
              (0.5, 1.5), (0.5, 0.5)]
# The left-hand search turns left at the entry: the same walk the other way round.
LEFT_HAND = [(1.5, 0.5), (0.5, 0.5), (0.5, 1.5), (0.5, 2.5), (1.5, 2.5), (2.5, 2.5),
             (3.5, 2.5), (4.5, 2.5), (4.5, 1.5), (5.5, 1.5), (5.5, 2.5), (6.5, 2.5),
             (6.5, 1.5), (6.5, 0.5), (5.5, 0.5), (5.5, 1.5), (4.5, 1.5), (4.5, 0.5),
             (3.5, 0.5), (2.5, 0.5)]
# The pillar's node (2.5, 1.5) is gone; the eight nodes around it form the inner-wall
# sequence, walked clockwise (pillar on the right hand), starting nearest the entrance.
INNER = [(1.5, 0.5), (1.5, 1.5), (1.5, 2.5), (2.5, 2.5), (3.5, 2.5), (3.5, 1.5),
         (3.5, 0.5), (2.5, 0.5)]


@pytest.fixture(scope="module")
def patterns():
    return extract_search_patterns(small_plan().build())


def test_grid_nodes_are_the_cell_centres(patterns):
    expected = {(x + 0.5, y + 0.5) for x in range(7) for y in range(3)} - {(2.5, 1.5)}
    assert {tuple(p) for p in np.round(patterns.nodes, 9)} == expected
    # edges: 18 in the main room, 7 in the side room, 1 through the partition door
    assert len(patterns.edges) == 26


def test_right_left_and_inner_sequences_match_the_hand_worked_walks(patterns):
    names = [(s.name, s.kind, s.hand, s.matched) for s in patterns.sequences]
    assert names == [("right_hand", "outer", "right", True), ("left_hand", "outer", "left", False),
                     ("inner_1", "inner", "right", True)]
    for name, expected in (("right_hand", RIGHT_HAND), ("left_hand", LEFT_HAND),
                           ("inner_1", INNER)):
        got = patterns.positions(patterns.sequence(name))
        np.testing.assert_allclose(got, np.array(expected), atol=1e-9, err_msg=name)


def test_subpatterns_are_overlapping_windows_with_the_paper_headings(patterns):
    sub = patterns.subpatterns(length_m=3.0)          # dN = 3: four nodes per pattern
    assert sub.points.shape == (20 + 8, 4, 2)          # one per start node of both sequences
    np.testing.assert_allclose(sub.points[0], RIGHT_HAND[:4], atol=1e-9)
    # the last patterns of the right-hand walk wrap round to its start (p_N next to p_1)
    np.testing.assert_allclose(sub.points[18], RIGHT_HAND[18:] + RIGHT_HAND[:2], atol=1e-9)
    # Hea(eta, 1) points back along the first step: from (2.5, .5) to (1.5, .5), west
    assert sub.first_heading[0] == pytest.approx(math.pi)
    # Hea(eta, 2) is the step after the last node: (4.5, .5) -> (4.5, 1.5), north
    assert sub.last_heading[0] == pytest.approx(math.pi / 2)
    assert tuple(patterns.nodes[sub.last_node[0]]) == pytest.approx((4.5, 0.5))
    inner = sub.sequence == 2
    np.testing.assert_allclose(sub.points[inner][0], INNER[:4], atol=1e-9)
    # patterns starting every 2 m instead of every node
    assert len(patterns.subpatterns(3.0, step_m=2.0)) == 10 + 4


def test_rotated_plan_gives_the_rotated_sequences():
    a = math.radians(20)
    rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    sp = extract_search_patterns(small_plan(20).build())
    # (plans store coordinates to 0.1 mm, so the recovered angle is that close)
    assert sp.angle[0] == pytest.approx(a, abs=1e-4)
    np.testing.assert_allclose(sp.positions(sp.sequence("right_hand")),
                               np.array(RIGHT_HAND) @ rot.T, atol=1e-3)
    np.testing.assert_allclose(sp.positions(sp.sequence("inner_1")),
                               np.array(INNER) @ rot.T, atol=1e-3)


def test_explicit_entrance_and_unreachable_rooms():
    sk = small_plan()
    sk.floors[0].room("closed", (7, 0, 9, 3))        # no door: a part of its own
    b = sk.build()
    sp = extract_search_patterns(b.floors[0], entrance=(6.5, 3.0, -math.pi / 2))
    names = [s.name for s in sp.sequences]
    assert names[:2] == ["right_hand", "left_hand"] and "part_1" in names
    # entering the side room from the north: first node (6.5, 2.5), right turn = west
    np.testing.assert_allclose(sp.positions(sp.sequence("right_hand"))[:2],
                               [(6.5, 2.5), (5.5, 2.5)], atol=1e-9)
    closed = sp.positions(sp.sequence("part_1"))
    assert len(closed) == 6 and np.all(closed[:, 0] > 7)


@pytest.mark.parametrize("plan", ["flat_125", "area_250"])
def test_right_hand_walk_visits_every_room_of_the_paper_plans(plan):
    b = load_building(bundled_plan(plan))
    sp = extract_search_patterns(b)
    walk = sp.positions(sp.sequence("right_hand"))
    for room in b.floors[0].rooms:
        assert shapely.contains_xy(room.polygon, walk[:, 0], walk[:, 1]).any(), room.id
    # consecutive nodes are grid neighbours (one spacing apart), also across the wrap
    steps = np.hypot(*(np.roll(walk, -1, axis=0) - walk).T)
    np.testing.assert_allclose(steps, 1.0, atol=1e-9)
    assert not any(s.kind == "inner" for s in sp.sequences)


def test_bad_arguments_are_refused():
    b = small_plan().build()
    with pytest.raises(ValueError, match="spacing"):
        extract_search_patterns(b, spacing=0)
    with pytest.raises(ValueError, match="entrance"):
        extract_search_patterns(b.floors[0], entrance=(1.0,))
    with pytest.raises(ValueError, match="length"):
        extract_search_patterns(b).subpatterns(0.0)


def test_draw_overlays_each_walked_sequence(patterns):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots()
    patterns.draw(ax, 0)
    labels = sorted(line.get_label() for line in ax.get_lines())
    plt.close(fig)
    assert labels == ["inner_1 (8 nodes)", "right_hand (20 nodes)"]
