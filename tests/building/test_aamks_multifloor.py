"""Multi-floor Aamks exports (written in Aamks's own format by aamks_exports.py): import,
map check, stairs from the stairwell geometry, storey heights, and firefighters walking
every floor of them in the simulator."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
import shapely
from shapely.geometry import Point, box

from firenav_framework.building import load_building
from firenav_framework.building.check import check_building
from firenav_framework.building.geojson_format import write_geojson
from firenav_framework.cli import main
from tests.building.aamks_exports import LEVELS, cad_export, write_exports

# The export's stairwells and doors, in metres (see aamks_exports.py).
BOX_A = box(17.0, 3.0, 24.0, 7.5)      # serves floors 0-2, door at the west end of its south side
BOX_B = box(-5.0, -2.0, 0.0, 9.0)      # serves floors 0-1: south door on 0, north door on 1


@pytest.fixture(scope="module")
def exports(tmp_path_factory):
    return write_exports(tmp_path_factory.mktemp("aamks"))


@pytest.fixture(scope="module", params=["cad", "static"])
def plan(request, exports):
    return load_building(exports[0] if request.param == "cad" else exports[1])


def stairs_in(building, footprint):
    return sorted((s for s in building.stairs if footprint.contains(Point(s.bottom))),
                  key=lambda s: s.floor_from)


def test_imports_with_its_floors_and_passes_check(plan):
    assert [f.z for f in plan.floors] == pytest.approx([z / 100 for z in LEVELS])
    assert [f.height for f in plan.floors][:2] == pytest.approx([3.5, 3.5])
    assert 3.5 <= plan.floors[2].height <= 3.55        # static: maxz_abs - minz_abs (a vent)
    assert [str(p) for p in check_building(plan) if p.severity == "error"] == []
    # Every stairwell slice is a room on the floors its tower reaches.
    stairwells = [[r.id.split("@")[0] for r in f.rooms if r.use == "stairwell"] for f in plan.floors]
    assert [len(s) for s in stairwells] == [2, 2, 1]


def door_probe(door, box):
    """A point 0.45 m inside the stairwell from a door's centre."""
    inward = np.asarray(box.centroid.coords[0]) - door.center
    return Point(door.center + 0.45 * inward / np.linalg.norm(inward))


def test_u_shaped_stairs_stack_in_stairwell_a(plan):
    up = stairs_in(plan, BOX_A)
    assert [(s.floor_from, s.floor_to) for s in up] == [(0, 1), (1, 2)]   # none above floor 2
    for s in up:
        assert (s.z_from, s.z_to) == pytest.approx((plan.floor(s.floor_from).z, plan.floor(s.floor_to).z))
        # The run comes from the rise: 19 risers of 3.5/19 m, comfortable goings.
        assert s.n_steps == math.ceil(3.5 / 0.19) and 0.22 <= s.going <= 0.30
        # Two flights side by side, turning at the far (east) end: up away from the door
        # end, back towards it.
        assert s.direction == pytest.approx([1.0, 0.0]) and s.top_direction == pytest.approx([-1.0, 0.0])
        assert abs(s.bottom[1] - s.top[1]) == pytest.approx(s.width)
        assert s.bottom[0] == pytest.approx(s.top[0])              # landing above landing
        assert 0.8 <= s.width <= 1.5                               # a stair, not the box
        assert BOX_A.buffer(1e-6).contains(s.polygon)
        assert s.polygon.bounds[2] == pytest.approx(24.0)          # half landing at the far end
        # Every door of the stairwell on both floors opens onto level floor beside it:
        # the south door at the west end and, on floor 0, the outside door in the east end.
        for fl in (s.floor_from, s.floor_to):
            doors = [d for d in plan.floor(fl).doors if BOX_A.exterior.distance(Point(d.center)) < 0.3]
            assert doors and not any(s.polygon.contains(door_probe(d, BOX_A)) for d in doors)
    # Stacked: the second stair starts where the first arrives on floor 1's landing.
    assert up[1].bottom == pytest.approx(up[0].bottom)
    assert up[1].polygon.equals(up[0].polygon)


def test_straight_flight_in_stairwell_b(plan):
    (s,) = stairs_in(plan, BOX_B)
    # Entered at its south end on floor 0 and its north end on floor 1: one flight north,
    # along the west wall, away from the doors in the east wall.
    assert (s.floor_from, s.floor_to) == (0, 1)
    assert s.direction == pytest.approx([0.0, 1.0]) and len(s.path) == 2
    assert s.width == pytest.approx(1.5) and s.polygon.bounds[0] == pytest.approx(-5.0)
    assert s.bottom[1] > 0.5 + 0.9 + 0.3 - 2.0 and s.top[1] < 7.6 - 0.3
    assert s.flight_length == pytest.approx(s.n_steps * s.going) and 0.22 <= s.going <= 0.30


def test_cad_and_static_agree(exports):
    cad, static = (load_building(p) for p in exports)
    assert [s.id for s in cad.stairs] == [s.id for s in static.stairs]
    for a, b in zip(cad.stairs, static.stairs):
        assert a.path == pytest.approx(b.path, abs=0.05)
    for fa, fb in zip(cad.floors, static.floors):
        assert sorted(d.id for d in fa.doors) == sorted(d.id for d in fb.doors)
        assert {r.id for r in fa.rooms} == {r.id for r in fb.rooms}
    # The floor-2 HOLE: drawn in cad, only a wall gap in static; both become an opening.
    (hole_cad,) = cad.floor(2).openings
    (hole_static,) = static.floor(2).openings
    np.testing.assert_allclose(sorted(hole_cad.jambs.tolist()), sorted(hole_static.jambs.tolist()),
                               atol=0.1)


def test_export_quirks_are_noted(exports):
    static = load_building(exports[1])
    notes = "\n".join(static.notes)
    # Aamks's zdim is the top of anything on the floor minus the floor below's: the
    # column through floor 2 and the roof vent make 6.5 m and 0.54 m of it.
    assert "floor 1: floor_meta zdim 6.50 m is not its storey height (3.50 m" in notes
    assert "floor 2: floor_meta zdim 0.54 m is not its storey height" in notes
    assert "wall(s) drawn twice merged" in notes
    assert "opening opening_c9_r10@2" in notes
    cad = "\n".join(load_building(exports[0]).notes)
    assert "STAI s14@0 rises to 10.50 m: also on floor(s) 1, 2" in cad
    assert "HALL a13@0 rises to 7.00 m: also on floor(s) 1" in cad
    assert "not plan geometry, skipped: 1 FIRE, 1 VVENT, 1 WIN" in cad
    assert "do not reach" not in cad               # every stairwell door reaches its stair


def test_map_check_reports_implausible_storeys(tmp_path, exports):
    # The levels a reader that believed zdim would produce: 0, 6.5, 7.04 m.
    b = load_building(exports[0])
    path = tmp_path / "plan.geojson"
    write_geojson(b, path)
    doc = json.loads(path.read_text())
    for f in doc["features"]:
        p = f["properties"]
        if p["kind"] == "floor":
            p["z"], p["height"] = {0: (0.0, 6.5), 1: (6.5, 0.54), 2: (7.04, 3.5)}[p["floor"]]
    path.write_text(json.dumps(doc))
    got = [(p.code, p.floor, p.message) for p in check_building(load_building(path))
           if p.code == "storey_height"]
    assert [(c, fl) for c, fl, _ in got] == [("storey_height", 0), ("storey_height", 1)]
    assert "storey 6.50 m high (from level 0.00 to 6.50 m)" in got[0][2]
    assert "storey 0.54 m high (from level 6.50 to 7.04 m)" in got[1][2]


def test_native_round_trip_keeps_the_stair_footprints(tmp_path, exports):
    b = load_building(exports[0])
    write_geojson(b, tmp_path / "plan.geojson")
    again = load_building(tmp_path / "plan.geojson")
    for a, c in zip(b.stairs, again.stairs):
        assert a.polygon.symmetric_difference(c.polygon).area < 1e-6
    assert [str(p) for p in check_building(again)] == []


SCENARIO = """
name: aamks_every_floor
building: {plan}
agents:
  - id: ff1
    start: {{entrance: entrance_d27@0}}
    sensors: {{imu: null}}
    plan:
      - stairs: {{to_floor: 2}}
      - walk: {{to: {{room: r10@2}}}}
      - stairs: {{to_floor: 0}}
      - walk: {{to: {{entrance: entrance_d17@0}}}}
  - id: ff2
    start: {{entrance: entrance_d17@0}}
    sensors: {{imu: null}}
    plan:
      - walk: {{to: {{door: d18@0}}}}
      - stairs: {{to_floor: 1}}
      - walk: {{to: {{room: c5@1}}}}
      - stairs: {{to_floor: 2}}
      - walk: {{to: {{room: c9@2}}}}
      - stairs: {{to_floor: 0}}
"""


@pytest.mark.parametrize("which", [0, 1], ids=["cad", "static"])
def test_two_firefighters_walk_every_floor(tmp_path, exports, which, capsys):
    from firenav_framework.simulator import load_scenario, simulate
    path = tmp_path / "every_floor.yaml"
    path.write_text(SCENARIO.format(plan=exports[which]))
    assert main(["simulate", str(path), "--out", str(tmp_path / "sim")]) == 0
    assert "2 agents" in capsys.readouterr().out
    result = simulate(load_scenario(path), 0)
    b = result.building
    for agent, stairwells in (("ff1", [BOX_A]), ("ff2", [BOX_B, BOX_A])):
        tr = result.truth[agent]
        floors = tr.floor
        changes = [int(floors[0])] + [int(f) for p, f in zip(floors, floors[1:]) if f != p]
        assert changes == [0, 1, 2, 1, 0]
        assert tr.position[:, 2].max() == pytest.approx(7.0, abs=0.05)
        # Height changes only inside the stairwells, and on the floor level elsewhere.
        level = np.array([b.floor(int(f)).z for f in floors])
        climbing = np.abs(tr.position[:, 2] - level) > 0.05
        inside = shapely.contains_xy(shapely.union_all([s.buffer(0.5) for s in stairwells]),
                                     tr.position[climbing, 0], tr.position[climbing, 1])
        assert climbing.any() and inside.all()
    # ff2 went up stairwell B (the stair nearest its start on floor 0).
    xy2 = result.truth["ff2"].position
    assert (xy2[:, 0] < 0).any() and (xy2[:, 2] > 1.0)[xy2[:, 0] < 0].any()


def test_every_floor_is_drawn_with_ids(tmp_path, exports):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from firenav_framework.building.plot import draw_floor, north_arrow, scale_bar
    b = load_building(exports[0])
    for f in b.floors:
        fig, ax = plt.subplots()
        draw_floor(ax, b, f.index, labels=True)
        assert scale_bar(ax) == 5.0                       # ~1/5 of a 34 m wide view
        assert north_arrow(ax, b) == pytest.approx([0.0, 1.0])   # no georef: plan north
        texts = " | ".join(t.get_text() for t in ax.texts)
        plt.close(fig)
        for d in f.doors + f.openings:
            assert d.id in texts
        for r in f.rooms:
            assert r.name in texts
        for s in b.stairs:
            if s.floor_from == f.index:
                assert f"{s.id}\nup to floor {s.floor_to}" in texts
            if s.floor_to == f.index:
                assert f"{s.id}\ndown to floor {s.floor_from}" in texts
        for e in b.entrances:
            assert (e.id in texts) == (e.floor == f.index)
        assert "5 m" in texts and "N (plan)" in texts
    assert main(["map", "show", str(exports[0]), "--out", str(tmp_path), "--dpi", "40"]) == 0
    assert len(list(tmp_path.glob("*.png"))) == 3


def test_cad_record_without_z_gets_a_noted_level(tmp_path):
    cad = cad_export()
    for kind in ("ROOM", "COR"):
        for item in cad["2"][kind]:
            del item["z"]
    path = tmp_path / "noz.cad.json"
    path.write_text(json.dumps(cad))
    b = load_building(path)
    assert b.floor(2).z == pytest.approx(7.0)
    assert any("floor 2: no z on its rooms; level 7.00 m from the lowest of its other records"
               in n for n in b.notes)
