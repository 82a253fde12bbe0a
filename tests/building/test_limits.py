"""One bad value in a plan file gives a located error in bounded time and memory, never a
hang or a traceback (the plan limits of building/limits.py)."""
from __future__ import annotations

import json

import ezdxf
import numpy as np
import pytest

from firenav_framework.building import BuildingError, load_building
from firenav_framework.building import geojson_format, limits
from firenav_framework.building.index import SegmentIndex, segments_hit_bruteforce
from firenav_framework.cli import main


def floor(i=0):
    return {"type": "Feature", "properties": {"kind": "floor", "floor": i, "z": 3.0 * i,
                                              "height": 3.0}, "geometry": None}


def wall(*pts, fl=0):
    return {"type": "Feature", "properties": {"kind": "wall", "floor": fl},
            "geometry": {"type": "LineString", "coordinates": [list(p) for p in pts]}}


def write_plan(path, *features):
    path.write_text(json.dumps({"type": "FeatureCollection", "features": list(features)}))
    return path


def dxf(path, build):
    doc = ezdxf.new()
    doc.units = ezdxf.units.M
    build(doc.modelspace())
    doc.saveas(path)
    return path


@pytest.mark.parametrize("cmd", [["check"], ["show", "--out", "."]])
def test_dxf_arc_of_radius_1e12(tmp_path, capsys, cmd, monkeypatch):
    monkeypatch.chdir(tmp_path)
    path = dxf(tmp_path / "arc.dxf", lambda m: (
        m.add_line((0, 0), (10, 0), dxfattribs={"layer": "WALL"}),
        m.add_arc((0, 0), radius=1e12, start_angle=0, end_angle=90, dxfattribs={"layer": "WALL"})))
    assert main(["map", cmd[0], str(path), *cmd[1:]]) == 2
    err = capsys.readouterr().err
    assert "(ARC on layer WALL)" in err and "farther than 100000 m from the plan origin" in err


def test_large_arcs_are_flattened_into_a_bounded_number_of_pieces(tmp_path):
    # 90 km radius, full circle: 5 cm sagitta would need ~2500 pieces; capped and noted.
    path = dxf(tmp_path / "ring.dxf", lambda m: m.add_arc((0, 0), radius=9e4, start_angle=0,
                                                          end_angle=360, dxfattribs={"layer": "WALL"}))
    b = load_building(path)
    assert len(b.floor(0).walls) == limits.MAX_ARC_SEGMENTS
    assert "arcs flattened coarser than 0.05 m to stay within 1024 pieces each: 1" in b.notes
    # A small arc keeps its 5 cm accuracy: r = 1 m, a quarter circle in 3 pieces (the
    # fewest whose chords stay within 5 cm: 1 - cos(15 deg) = 3.4 cm).
    small = load_building(dxf(tmp_path / "door.dxf", lambda m: m.add_arc(
        (0, 0), radius=1.0, start_angle=0, end_angle=90, dxfattribs={"layer": "WALL"})))
    segs = small.floor(0).walls
    mid = segs.mean(axis=1)
    assert len(segs) == 3 and np.all(1.0 - np.hypot(*mid.T) <= 0.05)


def test_polyline_bulges_become_bounded_arcs(tmp_path):
    # A bulge of 1e12 on a 1 m edge is a nearly full circle of radius 2.5e11 m.
    path = dxf(tmp_path / "bulge.dxf", lambda m: m.add_lwpolyline(
        [(0, 0, 0, 0, 1e12), (1, 0, 0, 0, 0)], format="xyseb", dxfattribs={"layer": "WALL"}))
    with pytest.raises(BuildingError, match=r"LWPOLYLINE on layer WALL.*farther than 100000 m"):
        load_building(path)
    # A half-circle bulge (1.0) on a 2 m edge: radius 1 m around (1, 0).
    ok = load_building(dxf(tmp_path / "half.dxf", lambda m: m.add_lwpolyline(
        [(0, 0, 0, 0, 1.0), (2, 0, 0, 0, 0)], format="xyseb", dxfattribs={"layer": "WALL"})))
    pts = ok.floor(0).walls.reshape(-1, 2)
    np.testing.assert_allclose(np.hypot(pts[:, 0] - 1.0, pts[:, 1]), 1.0, atol=1e-9)
    assert np.all(pts[:, 1] <= 1e-9) and pts[:, 1].min() < -0.9   # positive bulge: counter-clockwise


def test_layer_named_for_floor_99999(tmp_path, capsys):
    path = dxf(tmp_path / "floors.dxf", lambda m: m.add_line((0, 0), (10, 0),
                                                             dxfattribs={"layer": "F99999_WALL"}))
    assert main(["map", "check", str(path)]) == 2
    err = capsys.readouterr().err
    assert "(LINE on layer F99999_WALL): the layer name puts it on floor 99999" in err
    assert "at most 200 floors" in err


def test_twenty_thousand_random_walls(tmp_path, capsys):
    rng = np.random.default_rng(0)
    segs = rng.uniform(0, 100, (20_000, 2, 2))
    path = write_plan(tmp_path / "random.geojson", floor(), *[wall(*s) for s in segs.tolist()])
    for cmd in (["check"], ["show", "--out", str(tmp_path)]):
        assert main(["map", *cmd, str(path)]) == 2
        err = capsys.readouterr().err
        assert "floor 0: its 20000 wall segments touch or cross each other more than 200000 times" in err


def test_a_real_sized_floor_of_walls_loads():
    # 100 x 100 rooms of 3 x 3 m: 20 200 wall segments meeting at their ends.
    xs = np.arange(101) * 3.0
    h = [((x0, y), (x0 + 3.0, y)) for y in xs for x0 in xs[:-1]]
    v = [((x, y0), (x, y0 + 3.0)) for x in xs for y0 in xs[:-1]]
    b = geojson_format.parse_geojson({"type": "FeatureCollection",
                                      "features": [floor()] + [wall(*s) for s in h + v]})
    assert len(b.floor(0).walls) == 20_200
    assert b.floor(0).crosses_wall(np.array([[1.5, 1.5]]), np.array([[4.5, 1.5]])).tolist() == [True]


@pytest.mark.parametrize("value", [1e300, -1e300, 2e5])
def test_coordinates_far_from_the_origin(tmp_path, capsys, value):
    path = write_plan(tmp_path / "far.geojson", floor(), wall((0, 0), (value, 0)))
    assert main(["map", "check", str(path)]) == 2
    err = capsys.readouterr().err
    assert "feature 1:" in err and "farther than 100000 m from the plan origin" in err


def test_aamks_coordinates_and_levels_far_out(tmp_path):
    static = {"floors": {"0": {"floor_meta": {"minz_abs": 0}, "obstacles": [
        [[0, 0], [1e302, 0], [1e302, 4], [0, 4]]]}}}
    (tmp_path / "a.json").write_text(json.dumps(static))
    with pytest.raises(BuildingError, match=r"obstacles\[0\]: point \(1e\+300, 0\) m is farther"):
        load_building(tmp_path / "a.json")
    static["floors"]["0"] = {"floor_meta": {"minz_abs": 1e300}}
    (tmp_path / "a.json").write_text(json.dumps(static))
    with pytest.raises(BuildingError, match=r"floor_meta: minz_abs 1e\+298 m is beyond"):
        load_building(tmp_path / "a.json")
    many = {"floors": {str(i): {} for i in range(limits.MAX_FLOORS + 1)}}
    (tmp_path / "a.json").write_text(json.dumps(many))
    with pytest.raises(BuildingError, match="201 floors; a building may have at most 200"):
        load_building(tmp_path / "a.json")


@pytest.mark.parametrize("text, message", [
    ("[" * 100_000 + "]" * 100_000, "nested too deeply"),
    ('{"type": "FeatureCollection", "features": [], "n": 1' + "0" * 5000 + "}", "not valid JSON"),
    ("\xff\xfe{}", "not UTF-8"),
])
def test_json_that_cannot_be_a_plan(tmp_path, text, message):
    path = tmp_path / "x.geojson"
    path.write_bytes(text.encode("latin-1"))
    with pytest.raises(BuildingError, match=message):
        load_building(path)


def test_deeply_nested_coordinates(tmp_path):
    deep = 0
    for _ in range(50_000):
        deep = [deep]
    path = tmp_path / "deep.geojson"
    text = json.dumps({"type": "FeatureCollection", "features": [floor()]})[:-2]
    text += ', {"type": "Feature", "properties": {"kind": "wall", "floor": 0}, "geometry": ' \
            '{"type": "LineString", "coordinates": ' + "[" * 50_000 + "0" + "]" * 50_000 + "}}]}"
    path.write_text(text)
    with pytest.raises(BuildingError, match="nested too deeply"):
        load_building(path)


def test_devices_and_huge_files_are_not_read(tmp_path):
    with pytest.raises(BuildingError, match="/dev/zero: not a regular file"):
        load_building("/dev/zero")
    big = tmp_path / "big.geojson"
    with open(big, "wb") as fh:
        fh.truncate(limits.MAX_PLAN_BYTES + 1)       # sparse: nothing is written or read
    with pytest.raises(BuildingError, match="plans are limited to 64 MiB"):
        load_building(big)


def test_feature_and_item_limits(tmp_path, monkeypatch):
    monkeypatch.setattr(geojson_format, "MAX_FEATURES", 3)
    with pytest.raises(BuildingError, match="4 features; the limit is 3"):
        geojson_format.parse_geojson({"type": "FeatureCollection",
                                      "features": [floor()] + [wall((0, 0), (1, 0))] * 3})
    monkeypatch.setattr(geojson_format, "MAX_WALL_SEGMENTS_PER_FLOOR", 2)
    with pytest.raises(BuildingError, match=r"floor 0: 3 wall segments \(obstacle edges included\)"):
        geojson_format.parse_geojson({"type": "FeatureCollection",
                                      "features": [floor(), wall((0, 0), (1, 0), (1, 1), (0, 1))]})


def test_wall_grid_caps_its_cell_lists(monkeypatch):
    # Walls criss-crossing 100 km register in thousands of cells each; with a cap of
    # 200 000 entries the grid takes coarser cells and still answers exactly.
    from firenav_framework.building import index as index_module
    rng = np.random.default_rng(3)
    segs = rng.uniform(-5e4, 5e4, (3000, 2, 2))
    segs[:100] = rng.uniform(0, 10, (100, 2, 2))          # and a few small ones
    fine = SegmentIndex(segs)
    monkeypatch.setattr(index_module, "MAX_GRID_ITEMS", 200_000)
    coarse = SegmentIndex(segs)
    assert len(fine.cells[1]) > 200_000 >= len(coarse.cells[1]) and coarse.cell > fine.cell
    p0 = rng.uniform(-5e4, 5e4, (300, 2))
    p1 = p0 + rng.normal(0, 50, p0.shape)
    truth = segments_hit_bruteforce(p0, p1, segs)[0]
    assert truth.any() and not truth.all()
    assert np.array_equal(coarse.crosses(p0, p1), truth)
    assert np.array_equal(fine.crosses(p0, p1), truth)
