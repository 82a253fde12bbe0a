"""The native GeoJSON format: reading, writing, bundled plans and clear errors."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from firenav_framework.building import BuildingError, bundled_plan, bundled_plans, load_building
from firenav_framework.building.geojson_format import write_geojson
from firenav_framework.building.plans import PLANS

from .plan_files import write_plan

HAND_MADE = {
    "type": "FeatureCollection", "name": "hut",
    "features": [
        {"type": "Feature", "geometry": None,
         "properties": {"kind": "floor", "floor": 0, "z": 0.0, "height": 2.8, "name": "ground"}},
        {"type": "Feature", "geometry": {"type": "LineString", "coordinates":
                                         [[1, 0], [0, 0], [0, 4], [6, 4], [6, 0], [2, 0]]},
         "properties": {"kind": "wall", "floor": 0, "id": "outer"}},
        {"type": "Feature", "geometry": {"type": "LineString", "coordinates": [[2, 0], [1, 0]]},
         "properties": {"kind": "door", "floor": 0, "id": "front"}},
        {"type": "Feature", "geometry": {"type": "Polygon", "coordinates":
                                         [[[0, 0], [6, 0], [6, 4], [0, 4], [0, 0]]]},
         "properties": {"kind": "room", "floor": 0, "id": "hut", "use": "room"}},
        {"type": "Feature", "geometry": {"type": "Polygon", "coordinates":
                                         [[[4, 3], [5.5, 3], [5.5, 3.8], [4, 3.8], [4, 3]]]},
         "properties": {"kind": "obstacle", "floor": 0, "id": "bed"}},
        {"type": "Feature", "geometry": {"type": "Point", "coordinates": [3, 2, 7.5]},
         "properties": {"kind": "anchor", "floor": 0, "id": "uwb1", "anchor_kind": "uwb",
                        "height": 1.2}},
        {"type": "Feature", "geometry": {"type": "Point", "coordinates": [1.5, 0]},
         "properties": {"kind": "entrance", "floor": 0, "id": "in"}},
        {"type": "Feature", "geometry": {"type": "Point", "coordinates": [0, 0]},
         "properties": {"kind": "georef", "lat": 52.0, "lon": 5.0, "bearing_deg": 0}},
    ]}


def test_hand_made_plan(tmp_path):
    b = load_building(write_plan(tmp_path, HAND_MADE))
    f = b.floor(0)
    assert b.name == "hut" and (f.z, f.height, f.name) == (0.0, 2.8, "ground")
    assert len(f.walls) == 9            # 5 wall segments + 4 obstacle edges
    assert f.wall_is_obstacle.tolist() == [False] * 5 + [True] * 4
    assert f.wall_ids[:5] == ["outer"] * 5 and f.wall_ids[5:] == ["bed"] * 4
    (door,) = f.doors
    assert door.center.tolist() == [1.5, 0] and door.width == 1.0
    assert door.axis.tolist() == pytest.approx([0, -1])     # left normal of (2,0) -> (1,0)
    # The entrance takes the door axis turned to point into the hut: +y, 90 degrees.
    assert b.entrances[0].heading == pytest.approx(math.pi / 2) and b.entrances[0].door == "front"
    assert b.anchors[0].position.tolist() == [3, 2, 1.2]    # z = floor z + height, not the 3rd ordinate
    assert f.free_space.area == pytest.approx(24 - 1.2)
    assert f.crosses_wall(np.array([[3.0, 2.0]]), np.array([[4.5, 3.4]]))[0]   # into the bed
    assert b.georef.lat == 52.0


@pytest.mark.parametrize("name", ["flat_125", "area_250", "office_loop", "corridor", "three_storey"])
def test_bundled_plans_load_and_match_their_source(name, tmp_path):
    assert name in bundled_plans()
    b = load_building(bundled_plan(name))
    assert b.name == name and b.georef is not None and b.entrances and b.anchors
    # The shipped file is exactly what plans.py draws (regenerate with
    # `python -m firenav_framework.building.plans`).
    assert json.loads(bundled_plan(name).read_text()) == json.loads(json.dumps(PLANS[name]().geojson()))


def test_bundled_plans_have_the_papers_dimensions():
    flat = load_building(bundled_plan("flat_125")).floor(0)
    assert flat.outline.area == pytest.approx(125.0)
    assert all(len([d for d in flat.doors if _touches(d, r)]) >= 1 for r in flat.rooms)
    area = load_building(bundled_plan("area_250")).floor(0)
    assert area.outline.area == pytest.approx(253.0)
    loop = load_building(bundled_plan("office_loop"))
    ring = next(r for r in loop.floor(0).rooms if r.use == "corridor")
    # Centre line of the 2 m ring corridor: (outer + inner perimeter) / 2 = 100 m per lap.
    assert (ring.polygon.exterior.length + ring.polygon.interiors[0].length) / 2 == pytest.approx(100.0)
    corridor = load_building(bundled_plan("corridor")).floor(0)
    on_line = np.column_stack([[5.12, 12.27, 20.90, 25.90, 31.60, 35.85], np.full(6, 8.40)])
    assert (corridor.room_of(on_line) == [r.id for r in corridor.rooms].index("corridor")).all()
    assert corridor.nearest_wall(on_line)[0] == pytest.approx(np.full(6, 1.5))
    three = load_building(bundled_plan("three_storey"))
    assert [f.z for f in three.floors] == [0.0, 3.5, 7.0]
    assert [(s.floor_from, s.floor_to) for s in three.stairs] == [(0, 1), (1, 2)]


def _touches(door, room) -> bool:
    from shapely.geometry import Point
    return room.polygon.boundary.distance(Point(door.center)) < 1e-6


def test_write_read_round_trip(tmp_path):
    b = load_building(bundled_plan("three_storey"))
    out = tmp_path / "copy.geojson"
    write_geojson(b, out)
    c = load_building(out)
    for fa, fb in zip(b.floors, c.floors):
        np.testing.assert_allclose(fa.walls, fb.walls, atol=1e-4)
        assert [d.id for d in fa.doors] == [d.id for d in fb.doors]
        np.testing.assert_allclose([d.axis for d in fa.doors], [d.axis for d in fb.doors], atol=1e-6)
        assert [s.id for s in fa.stairs] == [s.id for s in fb.stairs]
    assert c.georef.lat == pytest.approx(b.georef.lat) and c.georef.bearing == b.georef.bearing
    assert [(e.id, round(e.heading, 4)) for e in c.entrances] == [(e.id, round(e.heading, 4)) for e in b.entrances]
    np.testing.assert_allclose([a.position for a in c.anchors], [a.position for a in b.anchors])


def _broken(**change):
    doc = json.loads(json.dumps(HAND_MADE))
    i = change.pop("index", 1)
    for k, v in change.items():
        if k == "geometry":
            doc["features"][i]["geometry"] = v
        else:
            doc["features"][i]["properties"][k] = v
    return doc


@pytest.mark.parametrize("doc, message", [
    (_broken(kind="wal"), r"feature 1 \(id 'outer'\): property 'kind' must be one of"),
    (_broken(floor=3), r"feature 1 \(id 'outer'\): floor 3 is not a declared floor"),
    (_broken(floor="0"), r"property 'floor' must be an integer"),
    (_broken(geometry={"type": "Point", "coordinates": [0, 0]}), r"wall needs a LineString"),
    (_broken(geometry={"type": "LineString", "coordinates": [[0, 0], [0, 0]]}), r"wall has no length"),
    (_broken(geometry={"type": "LineString", "coordinates": [[0, 0], ["a", 0]]}), r"malformed LineString"),
    (_broken(index=2, geometry={"type": "LineString", "coordinates": [[0, 0], [1, 0], [2, 0]]}),
     r"feature 2 \(id 'front'\): a door is a LineString of its two jamb points"),
    (_broken(index=0, height=-1), r"feature 0: property 'height' must be > 0"),
    (_broken(index=5, id="hut"), r"duplicate id 'hut'"),
    (_broken(index=6, door="nope"), r"entrance names door 'nope'"),
    (_broken(index=7, lat=123.0), r"georef lat must be"),
    (_broken(index=6, geometry={"type": "Point", "coordinates": []}), r"feature 6 \(id 'in'\): empty Point"),
    (_broken(index=0, z="ground"), r"property 'z' must be a finite number"),
    ({"type": "FeatureCollection", "features": []}, r"no 'floor' features"),
    ({"type": "Feature"}, r"must be a GeoJSON FeatureCollection"),
])
def test_invalid_plans_give_clear_errors(tmp_path, doc, message):
    with pytest.raises(BuildingError, match=message) as info:
        load_building(write_plan(tmp_path, doc))
    assert str(tmp_path) in str(info.value)


def test_unreadable_files(tmp_path):
    bad = tmp_path / "bad.geojson"
    bad.write_text("{not json")
    with pytest.raises(BuildingError, match="not valid JSON"):
        load_building(bad)
    with pytest.raises(BuildingError, match="no such plan file"):
        load_building(tmp_path / "missing.geojson")
    other = tmp_path / "plan.txt"
    other.write_text("x")
    with pytest.raises(BuildingError, match="unknown plan format '.txt'"):
        load_building(other)


def test_stair_properties_are_checked(tmp_path):
    doc = json.loads(json.dumps(HAND_MADE))
    doc["features"].append({"type": "Feature", "geometry": {"type": "LineString", "coordinates": [[1, 1], [3, 1]]},
                            "properties": {"kind": "stair", "floor": 0, "id": "s", "floor_to": 1, "n_steps": -2}})
    with pytest.raises(BuildingError, match=r"id 's'\): property 'n_steps' must be a positive count"):
        load_building(write_plan(tmp_path, doc))
    doc["features"][-1]["properties"].pop("n_steps")
    doc["features"][-1]["properties"]["width"] = 0
    with pytest.raises(BuildingError, match=r"property 'width' must be > 0"):
        load_building(write_plan(tmp_path, doc))
