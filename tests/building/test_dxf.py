"""DXF import through the layer map: units, floors from layer prefixes, every entity kind."""
from __future__ import annotations

import ezdxf
import numpy as np
import pytest

from firenav_framework.building import BuildingError, bundled_plan, load_building
from firenav_framework.building.check import check_building


def two_floor_drawing(path, unit=ezdxf.units.CM):
    """Two 400 x 300 cm rooms stacked on floors 0 and 1, drawn in centimetres."""
    doc = ezdxf.new()
    doc.units = unit
    msp = doc.modelspace()
    for f in (0, 1):
        pre = f"F{f}_"
        msp.add_lwpolyline([(250, 0), (400, 0), (400, 300), (0, 300), (0, 0), (150, 0)],
                           dxfattribs={"layer": pre + "WALL"})
        if f == 0:
            msp.add_line((150, 0), (250, 0), dxfattribs={"layer": pre + "DOOR"})
        else:   # the door upstairs is drawn as a 20 cm deep rectangle
            msp.add_lwpolyline([(150, -10), (250, -10), (250, 10), (150, 10)], close=True,
                               dxfattribs={"layer": pre + "A-DOOR"})
        msp.add_lwpolyline([(0, 0), (400, 0), (400, 300), (0, 300)], close=True,
                           dxfattribs={"layer": pre + "ROOM"})
    msp.add_line((50, 50), (350, 50), dxfattribs={"layer": "F0_STAIR"})
    msp.add_lwpolyline([(300, 200), (380, 200), (380, 280), (300, 280)], close=True,
                       dxfattribs={"layer": "F0_FURNITURE"})
    msp.add_point((200, 150), dxfattribs={"layer": "F0_ANCHOR"})
    msp.add_line((200, -100), (200, 50), dxfattribs={"layer": "F0_ENTRANCE"})
    msp.add_line((0, 0), (999, 999), dxfattribs={"layer": "DIMENSIONS"})   # unmapped: ignored
    msp.add_text("office", dxfattribs={"layer": "F0_WALL"})                 # unusable: counted
    doc.saveas(path)
    return path


def test_two_floor_drawing(tmp_path):
    b = load_building(two_floor_drawing(tmp_path / "house.dxf"))
    assert [(f.z, f.height) for f in b.floors] == [(0.0, 3.0), (3.0, 3.0)]
    f0, f1 = b.floors
    np.testing.assert_allclose(f0.walls[0], [[2.5, 0.0], [4.0, 0.0]])      # centimetres -> metres
    assert len(f0.walls) == 5 + 4 and f0.wall_is_obstacle.sum() == 4      # + furniture edges
    for f in (f0, f1):
        (d,) = f.doors
        assert d.center.tolist() == pytest.approx([2.0, 0.0]) and d.width == pytest.approx(1.0)
        assert abs(d.axis[1]) == pytest.approx(1.0)
    (s,) = f0.stairs
    assert (s.floor_from, s.floor_to, s.bottom.tolist(), s.top.tolist()) == (0, 1, [0.5, 0.5], [3.5, 0.5])
    assert b.anchors[0].position.tolist() == [2.0, 1.5, 1.0]
    assert b.entrances[0].heading == pytest.approx(np.pi / 2)
    assert "DXF unit: Centimeters ($INSUNITS 5)" in b.notes
    assert "skipped TEXT on wall layers (not usable): 1" in b.notes
    assert [p.code for p in check_building(b)] == []
    # Through the door: free; through the wall beside it: blocked.
    assert f0.crosses_wall(np.array([[2.0, -0.5], [1.0, -0.5]]), np.array([[2.0, 0.5], [1.0, 0.5]])).tolist() \
        == [False, True]


def test_ids_point_at_dxf_handles(tmp_path):
    b = load_building(two_floor_drawing(tmp_path / "house.dxf"))
    doc = ezdxf.readfile(tmp_path / "house.dxf")
    door = next(e for e in doc.modelspace() if e.dxf.layer == "F0_DOOR")
    assert b.floor(0).doors[0].id == f"door0_{door.dxf.handle}"


def test_sidecar_and_explicit_layer_maps(tmp_path):
    doc = ezdxf.new()
    doc.units = ezdxf.units.MM
    msp = doc.modelspace()
    msp.add_lwpolyline([(0, 0), (5000, 0), (5000, 4000), (0, 4000)], close=True, dxfattribs={"layer": "Murs"})
    msp.add_lwpolyline([(0, 0), (5000, 0), (5000, 4000), (0, 4000)], close=True, dxfattribs={"layer": "Pieces"})
    path = tmp_path / "maison.dxf"
    doc.saveas(path)
    # With the built-in table "Murs" is a wall (MUR*) but "Pieces" is unmapped.
    b = load_building(path)
    assert len(b.floor(0).walls) == 4 and not b.floor(0).rooms
    # A sidecar maps Pieces to rooms and sets the level.
    (tmp_path / "maison.layers.yaml").write_text(
        "unit: auto\nfloors: [{z: 12.5, height: 2.7, name: etage}]\n"
        "layers: {wall: ['MURS'], room: ['PIECE*']}\n")
    b = load_building(path)
    assert len(b.floor(0).rooms) == 1 and b.floor(0).z == 12.5 and b.floor(0).name == "etage"
    assert b.floor(0).outline.area == pytest.approx(20.0)                 # millimetres -> metres
    # An explicit map wins over the sidecar; unit forced to metres.
    other = tmp_path / "m.yaml"
    other.write_text("unit: m\nlayers: {wall: ['MURS']}\n")
    b = load_building(path, other)
    assert b.floor(0).walls.max() == 5000.0


def test_bundled_plan_through_dxf_matches_native(tmp_path):
    """Write flat_125's walls/doors/rooms to DXF lines and read them back."""
    native = load_building(bundled_plan("flat_125"))
    f = native.floor(0)
    doc = ezdxf.new()
    msp = doc.modelspace()
    for seg in f.walls:
        msp.add_line(tuple(seg[0]), tuple(seg[1]), dxfattribs={"layer": "A-WALL"})
    for d in f.doors:
        msp.add_line(tuple(d.jambs[0]), tuple(d.jambs[1]), dxfattribs={"layer": "A-DOOR"})
    for r in f.rooms:
        msp.add_lwpolyline(list(r.polygon.exterior.coords)[:-1], close=True, dxfattribs={"layer": "A-AREA"})
    doc.saveas(tmp_path / "flat.dxf")
    dxf = load_building(tmp_path / "flat.dxf").floor(0)
    np.testing.assert_allclose(dxf.walls, f.walls)
    np.testing.assert_allclose([d.axis for d in dxf.doors], [d.axis for d in f.doors])
    rng = np.random.default_rng(1)
    p0 = f.sample_free(2000, rng)
    p1 = p0 + rng.normal(0, 1.0, p0.shape)
    assert np.array_equal(dxf.crosses_wall(p0, p1), f.crosses_wall(p0, p1))
    assert [p.code for p in check_building(load_building(tmp_path / "flat.dxf"))] == []


@pytest.mark.parametrize("yaml_text, message", [
    ("unit: furlong\nlayers: {wall: [W]}\n", r"unit: .*unit must be auto or one of"),
    ("layers: {walls: [W]}\n", r"unknown feature kind\(s\) \['walls'\]"),
    ("floor_pattern: '^F(\\d+)_'\nlayers: {wall: [W]}\n", r"named group \(\?P<floor>"),
    ("layers: {wall: [W]}\nextra: 1\n", r"extra: Extra inputs are not permitted"),
    ("layers: [", r"map.yaml:1:10: YAML syntax error"),
    ("a: &a [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]\n" + "".join(
        f"{k}: &{k} [{', '.join(['*' + p] * 10)}]\n" for p, k in zip("abcde", "bcdef")),
     r"map.yaml:6:\d+: more than \d+ values once aliases are expanded"),
])
def test_bad_layer_maps(tmp_path, yaml_text, message):
    path = two_floor_drawing(tmp_path / "house.dxf")
    (tmp_path / "map.yaml").write_text(yaml_text)
    with pytest.raises(BuildingError, match=message):
        load_building(path, tmp_path / "map.yaml")


def test_bad_drawings(tmp_path):
    (tmp_path / "junk.dxf").write_text("not a drawing")
    with pytest.raises(BuildingError, match="cannot read the DXF drawing"):
        load_building(tmp_path / "junk.dxf")
    doc = ezdxf.new()
    doc.modelspace().add_line((0, 0), (1, 0), dxfattribs={"layer": "Layer 7"})
    doc.saveas(tmp_path / "nothing.dxf")
    with pytest.raises(BuildingError, match="no entity on any mapped layer.*Layer 7"):
        load_building(tmp_path / "nothing.dxf")
    doc = ezdxf.new()
    doc.modelspace().add_lwpolyline([(0, 0), (1, 0), (1, 1)], dxfattribs={"layer": "DOOR"})
    doc.saveas(tmp_path / "door.dxf")
    with pytest.raises(BuildingError, match=r"entity \w+ \(LWPOLYLINE on layer DOOR\): a door must be a LINE"):
        load_building(tmp_path / "door.dxf")
    with pytest.raises(BuildingError, match="only applies to DXF"):
        load_building(bundled_plan("flat_125"), tmp_path / "map.yaml")


def test_arcs_and_bulges_are_flattened(tmp_path):
    doc = ezdxf.new()
    msp = doc.modelspace()
    # A 4 x 4 m room whose east side is a half-circle bay (bulge 1) of radius 2 m.
    msp.add_lwpolyline([(0, 0, 0, 0, 0), (4, 0, 0, 0, 1), (4, 4, 0, 0, 0), (0, 4, 0, 0, 0)],
                       format="xyseb", close=True, dxfattribs={"layer": "WALL"})
    msp.add_arc((2, 6), 1.0, 0, 180, dxfattribs={"layer": "WALL"})
    doc.saveas(tmp_path / "bay.dxf")
    f = load_building(tmp_path / "bay.dxf").floor(0)

    def on_circle(centre, r):      # ezdxf flattens via Bezier curves: within 1 mm of the arc
        return f.walls[(np.abs(np.linalg.norm(f.walls - centre, axis=2) - r) < 1e-3).all(axis=1)]
    bay = on_circle([4.0, 2.0], 2.0)
    assert len(bay) >= 8                                        # flattened into many chords
    # Chord midpoints stay within the 5 cm sagitta of the true arc.
    assert (2.0 - np.linalg.norm(bay.mean(axis=1) - [4.0, 2.0], axis=1)).max() <= 0.05
    assert f.outline.area == pytest.approx(16 + np.pi * 2**2 / 2, rel=0.02)
    assert len(on_circle([2.0, 6.0], 1.0)) >= 4


def test_walls_drawn_twice_are_merged(tmp_path):
    # The same wall on two layers, and a second polyline repeating part of the outline.
    doc = ezdxf.new()
    doc.units = ezdxf.units.M
    msp = doc.modelspace()
    msp.add_lwpolyline([(0, 0), (4, 0), (4, 3), (0, 3)], close=True, dxfattribs={"layer": "WALL"})
    msp.add_line((0, 0), (4, 0), dxfattribs={"layer": "A-WALL"})
    msp.add_line((4, 1), (4, 2.5), dxfattribs={"layer": "WALL"})
    msp.add_lwpolyline([(0, 0), (4, 0), (4, 3), (0, 3)], close=True, dxfattribs={"layer": "ROOM"})
    doc.saveas(tmp_path / "twice.dxf")
    b = load_building(tmp_path / "twice.dxf")
    f = b.floor(0)
    assert len(f.walls) == 4
    assert sorted(np.round(np.linalg.norm(f.walls[:, 1] - f.walls[:, 0], axis=1), 6)) == [3, 3, 4, 4]
    (note,) = [n for n in b.notes if "drawn twice merged" in n]
    assert note.startswith("floor 0: 2 wall(s) drawn twice merged:")
    assert check_building(b) == []
