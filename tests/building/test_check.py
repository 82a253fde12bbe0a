"""`map check` problems on deliberately broken plans, and the bundled plans passing."""
from __future__ import annotations

import json

import pytest

from firenav_framework.building import bundled_plan, bundled_plans, load_building
from firenav_framework.building.check import check_building
from firenav_framework.building.geojson_format import parse_geojson


def feat(kind, geometry, **props):
    return {"type": "Feature", "geometry": geometry, "properties": {"kind": kind, "floor": 0, **props}}


def line(*pts):
    return {"type": "LineString", "coordinates": [list(p) for p in pts]}


def poly(*pts):
    return {"type": "Polygon", "coordinates": [[list(p) for p in pts] + [list(pts[0])]]}


def plan(*features, floors=1):
    fl = [feat("floor", None, floor=i, z=3.0 * i, height=3.0) | {} for i in range(floors)]
    for i, f in enumerate(fl):
        f["properties"]["floor"] = i
    return parse_geojson({"type": "FeatureCollection", "features": fl + list(features)}, where="test")


# A closed 4 x 3 m room with a door in its south wall at x 1.5..2.5.
CLOSED = [feat("wall", line((1.5, 0), (0, 0), (0, 3), (4, 3), (4, 0), (2.5, 0)), id="w"),
          feat("door", line((1.5, 0), (2.5, 0)), id="d"),
          feat("room", poly((0, 0), (4, 0), (4, 3), (0, 3)), id="r")]


def codes(building):
    return [(p.severity, p.code, p.feature, p.xy) for p in check_building(building)]


def test_closed_room_is_clean():
    assert codes(plan(*CLOSED)) == []


def test_door_not_on_a_wall():
    got = codes(plan(*CLOSED, feat("door", line((1.0, 1.5), (1.0, 2.4)), id="ghost")))
    assert got == [("error", "door_not_on_wall", "door ghost", (1.0, 1.5))]
    p = check_building(plan(*CLOSED, feat("door", line((1.0, 1.5), (1.0, 2.4)), id="ghost")))[0]
    assert "jamb is 1.00 m from the nearest wall" in p.message
    assert str(p).startswith("error: floor 0 (1.00, 1.50) door ghost: jamb is 1.00 m")


def test_door_blocked_by_a_wall():
    got = codes(plan(*CLOSED, feat("wall", line((2.0, -1.0), (2.0, 1.0)), id="through")))
    assert ("error", "door_blocked", "door d", (2.0, 0.0)) in got


def test_dangling_walls_leave_the_room_open():
    walls = [feat("wall", line((1.5, 0), (0, 0), (0, 3), (4, 3), (4, 2.2)), id="w1"),
             feat("wall", line((4, 1.0), (4, 0), (2.5, 0)), id="w2")]
    got = codes(plan(*walls, *CLOSED[1:]))
    assert ("error", "dangling_wall", "wall w1", (4.0, 2.2)) in got
    assert ("error", "dangling_wall", "wall w2", (4.0, 1.0)) in got
    assert ("error", "room_open", "room r", (4.0, 1.6)) in got
    msg = next(p.message for p in check_building(plan(*walls, *CLOSED[1:])) if p.code == "room_open")
    assert "along 1.10 m" in msg      # the 1.2 m gap less 0.05 m join tolerance per end
    assert len(got) == 3


def test_free_standing_inner_wall_is_only_a_warning():
    got = codes(plan(*CLOSED, feat("wall", line((1, 1.5), (3, 1.5)), id="inner")))
    assert got == [("warning", "free_wall_end", "wall inner", (1.0, 1.5)),
                   ("warning", "free_wall_end", "wall inner", (3.0, 1.5))]


def test_overlapping_duplicate_walls():
    got = codes(plan(*CLOSED, feat("wall", line((0.5, 3.0), (2.5, 3.0)), id="again")))
    assert got == [("error", "duplicate_wall", "walls w and again", (1.5, 3.0))]
    # Continuing end to end is not a duplicate (a wall sticking out of the building is
    # legal but unusual: its free end is a warning).
    assert codes(plan(*CLOSED, feat("wall", line((4, 3), (6, 3)), id="on"))) == [
        ("warning", "free_wall_end", "wall on", (6.0, 3.0))]


def test_stair_that_connects_nothing():
    stair = feat("stair", line((1, 1), (3, 1)), id="s", floor_to=2)
    got = codes(plan(*CLOSED, stair))
    assert got == [("error", "stair_unconnected", "stair s", (3.0, 1.0))]
    ok = codes(plan(*CLOSED, *[dict(f, properties=dict(f["properties"], floor=1, id=f["properties"]["id"] + "1"))
                              for f in CLOSED], feat("stair", line((1, 1), (3, 1)), id="s", floor_to=1),
                    floors=2))
    # Joined now; only its pitch is off (3 m in 2 m).
    assert ok == [("warning", "stair_steep", "stair s", (1.0, 1.0))]


@pytest.mark.parametrize("run, code", [(2.0, "stair_steep"), (4.2, None), (9.0, "stair_shallow")])
def test_stair_pitch(run, code):
    # A 3 m rise in 15 steps of 0.20 m (the nominal step) over `run` metres: goings of
    # 0.13 m are a ladder, 0.28 m a stair, 0.60 m a walking line drawn over the landings.
    hall = [feat("wall", line((0, 0), (10, 0), (10, 3), (0, 3), (0, 0)), id="w", floor=f)
            for f in (0, 1)]
    stair = feat("stair", line((0.5, 1.5), (0.5 + run, 1.5)), id="s", floor_to=1)
    got = [c for c in codes(plan(*hall, stair, floors=2)) if c[1].startswith("stair")]
    assert got == ([] if code is None else [("warning", code, "stair s", (0.5, 1.5))])


def test_stair_end_outside_the_building():
    got = codes(plan(*CLOSED, *[dict(f, properties=dict(f["properties"], floor=1, id=f["properties"]["id"] + "1"))
                               for f in CLOSED], feat("stair", line((1, 1), (6, 1)), id="s", floor_to=1),
                     floors=2))
    assert got == [("error", "stair_end_outside", "stair s", (6.0, 1.0))]


def test_self_intersecting_room():
    bowtie = feat("room", poly((0, 0), (4, 3), (4, 0), (0, 3)), id="bow")
    got = codes(plan(*CLOSED, bowtie))
    assert ("error", "room_invalid", "room bow", (2.0, 1.5)) in got
    p = next(p for p in check_building(plan(*CLOSED, bowtie)) if p.code == "room_invalid")
    assert "self-intersecting" in p.message


def test_real_aamks_exports_pass(shared_data):
    # The static export draws two walls twice: merged on import, so not an error.
    for name in ("simple.static.json", "simple.cad.json"):
        assert codes(load_building(shared_data / "aamks" / name)) == []


def test_walls_drawn_twice_in_a_native_plan_are_reported(shared_data):
    # The same real walls, written out as a native plan without the importer's merge.
    from firenav_framework.building.aamks import _read_static, _static_features
    from firenav_framework.building.geojson_format import parse_geojson
    data = json.loads((shared_data / "aamks" / "simple.static.json").read_text())
    feats = _static_features(_read_static(data, "simple", []), [])
    b = parse_geojson({"type": "FeatureCollection", "features": feats})
    # Obstacles 0 and 5 are the same rectangle; 6 repeats the lower part of 1 (cm 805..1004).
    assert codes(b) == [("error", "duplicate_wall", "walls obstacle0@0 and obstacle5@0", (10.02, 5.67)),
                        ("error", "duplicate_wall", "walls obstacle1@0 and obstacle6@0", (10.02, 9.045))]


@pytest.mark.parametrize("name", bundled_plans())
def test_bundled_plans_pass(name):
    assert codes(load_building(bundled_plan(name))) == []
