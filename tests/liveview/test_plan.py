"""The plan as the page draws it, and where true north is in it."""
from __future__ import annotations

import math

import numpy as np
import pytest

from firenav_framework.building import bundled_plan, load_building
from firenav_framework.building.georef import GeoRef
from firenav_framework.liveview.plan import building_json, north_in_plan, true_turn


@pytest.mark.parametrize("bearing, north", [(0.0, (0.0, 1.0)), (90.0, (-1.0, 0.0)),
                                            (20.0, (-math.sin(math.radians(20)),
                                                    math.cos(math.radians(20))))])
def test_north_in_plan_follows_the_bearing(bearing, north):
    ref = GeoRef(lat=46.5, lon=6.6, bearing=bearing)
    n = north_in_plan(ref)
    assert n["true"] and (n["x"], n["y"]) == pytest.approx(north, abs=1e-3)
    # the same direction, independently: the plan point 100 m along it is due north
    far = ref.to_wgs84(np.array([[100 * north[0], 100 * north[1]]]))[0]
    assert far[0] == pytest.approx(ref.lon, abs=1e-9) and far[1] > ref.lat
    # true_turn takes that plan direction to (east, north) = (0, 1)
    assert true_turn(ref) @ np.array(north) == pytest.approx([0.0, 1.0], abs=1e-9)
    assert north_in_plan(None) == {"x": 0.0, "y": 1.0, "true": False}


def test_building_json_has_what_the_page_draws():
    b = load_building(bundled_plan("three_storey"))
    plan = building_json(b)
    assert [f["index"] for f in plan["floors"]] == [0, 1, 2]
    ground, first, top = plan["floors"]
    assert len(ground["walls"]) == int((~b.floors[0].wall_is_obstacle).sum())
    assert {r["name"] for r in ground["rooms"]} >= {"entrance lobby", "corridor", "stairwell"}
    assert [e["id"] for e in ground["entrances"]] == ["main"]
    # a stair is drawn where it starts (up) and where it arrives (down), never above the top
    assert [(s["id"], s["arrives"]) for s in ground["stairs"]] == [("stair01", False)]
    assert sorted((s["id"], s["arrives"]) for s in first["stairs"]) == \
        [("stair01", True), ("stair12", False)]
    assert [(s["id"], s["arrives"]) for s in top["stairs"]] == [("stair12", True)]
    assert plan["north"]["true"] and plan["georef"]["bearing_deg"] == 20.0
    assert building_json(None)["floors"] == []
