"""Stairs laid out in a stairwell box from its doors and the floor levels."""
from __future__ import annotations

import numpy as np
import pytest
from shapely.geometry import Point, box

from firenav_framework.building.stairwells import StairwellSlice, stairwell_stairs


def door(ident, x0, y0, x1, y1):
    return ident, np.array([[x0, y0], [x1, y1]], float)


def slices(poly, doors_per_floor, levels=(0.0, 3.5, 7.0)):
    return [StairwellSlice(k, levels[k], poly, doors) for k, doors in enumerate(doors_per_floor)]


@pytest.mark.parametrize("far", [False, True])
def test_bottom_is_where_the_lower_floor_enters_not_nearest_the_origin(far):
    # A 10 x 4 m stairwell entered at one end on floor 0 and at the other on floor 1: a
    # straight flight from the floor-0 door end, whichever end is nearer the origin.
    poly = box(100.0, 0.0, 110.0, 4.0)
    west, east = door("dw", 100.0, 1.0, 100.0, 2.0), door("de", 110.0, 1.0, 110.0, 2.0)
    lower, upper = (east, west) if far else (west, east)
    (f,), notes = stairwell_stairs("s", slices(poly, [[lower], [upper]]))
    path = np.array(f["geometry"]["coordinates"])
    assert f["properties"]["floor"] == 0 and f["properties"]["floor_to"] == 1
    assert (path[0][0] > 105) == far and (path[-1][0] > 105) != far
    assert "straight flight" in notes[0]


def test_no_stair_above_the_top_floor_and_none_for_one_floor():
    poly = box(0, 0, 7, 4.5)
    d = door("d", 0.0, 1.0, 0.0, 2.0)
    feats, _ = stairwell_stairs("s", slices(poly, [[d], [d], [d]]))
    assert [(f["properties"]["floor"], f["properties"]["floor_to"]) for f in feats] == [(0, 1), (1, 2)]
    assert stairwell_stairs("s", slices(poly, [[d]])) == ([], ["stairwell s is on floor 0 only: no stair"])


def test_a_box_too_short_for_the_rise_joins_nothing():
    feats, notes = stairwell_stairs("s", slices(box(0, 0, 2.5, 2.0), [[], []]))
    assert feats == [] and "is too small for a stair: floors 0 and 1 are not joined" in notes[-1]


def test_a_narrow_stairwell_says_which_door_cannot_reach_the_stair():
    # 7 x 2 m, doors in both ends on floor 0, the west one upstairs: a U-shaped stair
    # needs the whole width, so the east door opens under its half landing.
    poly = box(0, 0, 7, 2.0)
    west, east = door("dw", 0.0, 0.5, 0.0, 1.4), door("de", 7.0, 0.5, 7.0, 1.4)
    (f,), notes = stairwell_stairs("s", slices(poly, [[west, east], [west]]))
    assert "U-shaped stair" in notes[0]
    assert notes[1] == ("stairwell s floor 0: door(s) de do not reach the bottom of stair "
                        "stair_s_0_1 (no room beside the flights)")
    # With room beside the flights (4 m wide) both doors reach it.
    (f,), notes = stairwell_stairs("s", slices(box(0, 0, 7, 4.0), [[west, east], [west]]))
    assert not any("do not reach" in n for n in notes)
    foot = np.array(f["properties"]["footprint"])
    assert not box(*foot.min(axis=0), *foot.max(axis=0)).contains(Point(6.55, 0.95))
