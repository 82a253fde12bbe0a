"""Aamks imports: the real export in ../shared/data/aamks and small hand-made files."""
from __future__ import annotations

import numpy as np
import pytest
import shapely

from firenav_framework.building import BuildingError, load_building

from .plan_files import write_plan

# Two rooms side by side (cm): walls as 10 cm thick rectangles, one door between them,
# a wardrobe (an obstacle that is not a thin wall) and the ORCA paper's string-free form.
HAND_MADE_STATIC = {
    "floors": {
        "0": {
            "floor_meta": {"name": "0", "minz_abs": 0, "zdim": 300},
            "rooms": {
                "a": {"name": "a", "type_sec": "ROOM", "points": [[0, 0], [400, 0], [400, 300], [0, 300]]},
                "b": {"name": "b", "type_sec": "COR", "points": "[[400, 0], [800, 0], [800, 300], [400, 300]]"},
            },
            "doors": {
                "d": {"name": "d", "type_sec": "DOOR", "points": [[390, 100], [410, 100], [410, 190], [390, 190]]},
            },
            "obstacles": [
                [[0, -5], [800, -5], [800, 5], [0, 5]],          # south wall
                [[0, 295], [800, 295], [800, 305], [0, 305]],    # north wall
                [[-5, 5], [5, 5], [5, 295], [-5, 295]],          # west wall
                [[795, 5], [805, 5], [805, 295], [795, 295]],    # east wall
                [[395, 5], [405, 5], [405, 100], [395, 100]],    # partition below the door
                [[395, 190], [405, 190], [405, 295], [395, 295]],  # partition above the door
                [[600, 200], [700, 200], [700, 260], [600, 260]],  # wardrobe 1.0 x 0.6 m
            ],
        },
        "1": {
            "floor_meta": {"name": "1", "minz_abs": 300, "zdim": 300},
            "rooms": {"c": {"name": "c", "type_sec": "ROOM", "points": [[0, 0], [800, 0], [800, 300], [0, 300]]}},
            "doors": {},
            "obstacles": [],
        },
    }
}


def test_hand_made_static_export(tmp_path):
    b = load_building(write_plan(tmp_path, HAND_MADE_STATIC, "plan.json"))
    assert [(f.z, f.height) for f in b.floors] == [(0.0, 3.0), (3.0, 3.0)]
    f = b.floor(0)
    walls = f.walls[~f.wall_is_obstacle]
    # Centre lines, lengthened by half the 10 cm thickness at each end.
    np.testing.assert_allclose(walls[0], [[-0.05, 0.0], [8.05, 0.0]])
    np.testing.assert_allclose(sorted(walls[4][:, 1].tolist()), [0.0, 1.05])
    assert [o.id for o in f.obstacles] == ["obstacle6@0"]
    assert f.obstacles[0].polygon.area == pytest.approx(0.6)
    (d,) = f.doors
    assert d.center.tolist() == pytest.approx([4.0, 1.45]) and d.width == pytest.approx(0.9)
    assert d.axis.tolist() == pytest.approx([1.0, 0.0])
    assert [r.use for r in f.rooms] == ["room", "corridor"]
    # Door gap open, partition closed, wardrobe blocks.
    p0 = np.array([[3.5, 1.45], [3.5, 2.5], [5.0, 2.3]])
    p1 = np.array([[4.5, 1.45], [4.5, 2.5], [6.5, 2.3]])
    assert f.crosses_wall(p0, p1).tolist() == [False, True, True]
    assert not b.entrances                           # the only door is interior
    assert "centimetres" in b.notes[0]


def test_orca_obstacles_only_file(tmp_path):
    # The form printed in the ORCA paper (Sec. 2.2): floor "1" -> rectangles in cm.
    data = {"obstacles": {"1": [[[1394, 994], [1500, 994], [1500, 990], [1394, 990]],
                                [[1135, 990], [1014, 990], [1014, 994], [1135, 994]]]}}
    b = load_building(write_plan(tmp_path, data, "plan.json"))
    walls = np.sort(b.floor(0).walls, axis=1)       # end points in x order
    np.testing.assert_allclose(walls, [[[13.92, 9.92], [15.02, 9.92]],
                                       [[10.12, 9.92], [11.37, 9.92]]], atol=1e-9)


def test_real_static_export(shared_data):
    b = load_building(shared_data / "aamks" / "simple.static.json")
    f = b.floor(0)
    assert (f.z, f.height) == (0.0, 3.5)
    # 11 wall rectangles, two of them repeats (obstacles 0 and 5 are one rectangle, 6 is
    # the lower part of 1, cm 805..1004): merged into 9 segments and noted.
    assert len(f.walls) == 9 and not f.obstacles
    assert ("floor 0: 2 wall(s) drawn twice merged: obstacle5@0 into obstacle0@0 at (10.02, "
            "5.67); obstacle6@0 into obstacle1@0 at (10.02, 14.04)") in b.notes
    merged = f.walls[f.wall_ids.index("obstacle1@0")]
    np.testing.assert_allclose(sorted(merged[:, 1]), [8.03, 20.06])   # cm 805..2004 + 2 cm
    assert {r.id: round(r.polygon.area, 4) for r in f.rooms} == {"r1@0": 80.0425, "c2@0": 72.2475}
    doors = {d.id: d for d in f.doors}
    assert doors["d1@0"].center.tolist() == pytest.approx([10.0, 7.6])
    assert doors["d1@0"].width == pytest.approx(0.9)
    assert doors["d2@0"].center.tolist() == pytest.approx([22.35, 7.2])
    # d2 is on the outline (x = 22.35): an entrance heading west, into the corridor.
    (e,) = b.entrances
    assert e.door == "d2@0" and np.cos(e.heading) == pytest.approx(-1.0)
    # Through door d1 from the room into the corridor; beside it, the wall blocks.
    assert f.crosses_wall(np.array([[9.5, 7.6], [9.5, 9.0]]), np.array([[10.5, 7.6], [10.5, 9.0]])).tolist() \
        == [False, True]
    assert f.room_of(np.array([[7.0, 12.0], [15.0, 7.0]])).tolist() == [0, 1]


def test_real_cad_export_matches_static(shared_data):
    static = load_building(shared_data / "aamks" / "simple.static.json").floor(0)
    cad = load_building(shared_data / "aamks" / "simple.cad.json").floor(0)
    assert (cad.z, cad.height) == (0.0, 3.5)
    np.testing.assert_allclose([d.center for d in cad.doors], [d.center for d in static.doors])
    assert cad.outline.area == pytest.approx(static.outline.area)
    # Same blocking behaviour on random moves, except those that pass within 10 cm of a
    # door jamb or start or end near a wall (static walls are 2 cm off the cad outlines, their door
    # gaps 6 cm narrower).
    rng = np.random.default_rng(0)
    p0 = cad.sample_free(3000, rng)
    p1 = p0 + rng.normal(0, 1.0, p0.shape)
    moves = shapely.linestrings(np.stack([p0, p1], axis=1))
    jambs = shapely.multipoints(np.concatenate([d.jambs for d in cad.doors]))
    far = (shapely.distance(moves, jambs) > 0.1) & (cad.nearest_wall(p1)[0] > 0.1) \
        & (cad.nearest_wall(p0)[0] > 0.1)
    assert far.sum() > 2500
    assert np.array_equal(cad.crosses_wall(p0, p1)[far], static.crosses_wall(p0, p1)[far])


@pytest.mark.parametrize("data, message", [
    ({"floors": {"0": {"obstacles": ["[[0, 0], [1, 0]"]}}}, r"floors\['0'\]\.obstacles\[0\]: points string is not a JSON array"),
    ({"floors": {"0": {"obstacles": [[[0, 0], [1, 0]]]}}}, r"obstacles\[0\]: points must be at least three"),
    ({"floors": {"0": {"rooms": {"r": {"points": [[0, 0], [1, "x"], [1, 1]]}}}}}, r"rooms\['r'\]: points must be a list"),
    ({"floors": {"ground": {}}}, r"floor name 'ground' is not a number"),
    ({"floors": {"0": {"floor_meta": {"zdim": "tall"}}}}, r"floors\['0'\]\.floor_meta: zdim must be a number of centimetres"),
    ({"floors": {"0": {"rooms": [[0, 0]]}}}, r"floors\['0'\]: rooms must be an object of named objects"),
    ({"floors": {"0": {"obstacles": {"a": 1}}}}, r"obstacles must be a list"),
    ({"obstacles": {"1": "[[0, 0]]"}}, r"'obstacles' must map floor names to lists of polygons"),
    ({"0": {"ROOM": ["[[0,0],[1,0],[1,1]]"]}}, r"\['0'\]: ROOM must be a list of objects"),
    ({"0": {"ROOM": [{"points": "[[0,0],[100,0],[100,100]]", "z": "[0"}]}}, r"ROOM\[0\]: z string is not a JSON array"),
    ({"0": {"ROOM": [{"points": "[[0,0],[100,0],[100,100]]", "z": "[0, 1, 2]"}]}}, r"z must be \[z0, z1\]"),
])
def test_bad_aamks_files(tmp_path, data, message):
    with pytest.raises(BuildingError, match=message):
        load_building(write_plan(tmp_path, data, "plan.json"))


SIMPLE_WALK = """
name: simple_two_firefighters
building: {plan}
agents:
  - id: ff1
    start: {{entrance: entrance_d2@0}}
    sensors: {{imu: null}}
    plan:
      - walk: {{to: {{room: r1@0}}}}
      - walk: {{to: {{entrance: entrance_d2@0}}}}
  - id: ff2
    start: {{entrance: entrance_d2@0}}
    sensors: {{imu: null}}
    plan:
      - search: {{hand: right, laps: 1}}
"""


@pytest.mark.parametrize("name", ["simple.static.json", "simple.cad.json"])
def test_real_exports_are_drawn_with_ids_and_walked(shared_data, tmp_path, name):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from firenav_framework.building.check import check_building
    from firenav_framework.building.plot import draw_floor
    from firenav_framework.simulator import load_scenario, simulate

    b = load_building(shared_data / "aamks" / name)
    assert [str(p) for p in check_building(b)] == []
    fig, ax = plt.subplots()
    draw_floor(ax, b, 0, labels=True)
    texts = {t.get_text() for t in ax.texts}
    plt.close(fig)
    assert {"d1@0", "d2@0", "entrance_d2@0", "r1", "c2"} <= texts
    scenario = tmp_path / "walk.yaml"
    scenario.write_text(SIMPLE_WALK.format(plan=shared_data / "aamks" / name))
    result = simulate(load_scenario(scenario), 0)
    f = b.floor(0)
    for agent in ("ff1", "ff2"):
        rooms = set(f.room_of(result.truth[agent].position[:, :2]).tolist())
        assert {0, 1} <= rooms                         # both the room and the corridor
        assert not f.crosses_wall(result.truth[agent].position[:-1, :2],
                                  result.truth[agent].position[1:, :2]).any()
