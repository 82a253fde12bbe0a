"""Floor and building queries on small plans drawn in code, with hand-computed answers."""
from __future__ import annotations

import math

import numpy as np
import pytest

from firenav_framework.building import BuildingError, GeoRef, Stair, load_building, bundled_plan
from firenav_framework.building.sketch import PlanSketch


def two_rooms(levels: int = 1) -> PlanSketch:
    """Rooms A (x 0..4) and B (x 4..8), y 0..3, a 1 m door between them at y = 1.5,
    an exterior door on A's west wall; optionally more storeys with a straight stair."""
    sk = PlanSketch("two_rooms")
    for level in range(levels):
        f = sk.floor(3.0 * level, 3.0)
        f.room(f"A{level}", (0, 0, 4, 3), "A").room(f"B{level}", (4, 0, 8, 3), "B")
        f.door(f"dAB{level}", (4, 1.5), 1.0, (1, 0))
        if level + 1 < levels:
            f.stair(f"s{level}", [(5, 0.6), (7.5, 0.6)], floor_to=level + 1, width=1.0)
    sk.floors[0].door("front", (0, 1.5), 1.0, (1, 0))
    sk.entrance("main", (0, 1.5), door="front")
    sk.anchor("base", (-2, 1.5), height=1.0, kind="base_station")
    return sk


@pytest.fixture(scope="module")
def plan():
    return two_rooms().build()


def test_walls_have_door_gaps(plan):
    f = plan.floor(0)
    # Outline 8 x 3 (22 m) + partition 3 m, minus two 1 m gaps.
    assert np.linalg.norm(f.walls[:, 1] - f.walls[:, 0], axis=1).sum() == pytest.approx(23.0)
    moves = np.array([[[3.5, 1.5], [4.5, 1.5]],     # through the door gap
                      [[3.5, 2.5], [4.5, 2.5]],     # through the partition
                      [[-1, 1.5], [1, 1.5]],        # through the front door
                      [[2, 2], [2, 3]]])            # ends exactly on the north wall
    assert f.crosses_wall(moves[:, 0], moves[:, 1]).tolist() == [False, True, False, True]


def test_door_attributes(plan):
    d = plan.door("dAB0")
    assert d.center.tolist() == [4, 1.5] and d.width == pytest.approx(1.0)
    assert d.axis.tolist() == pytest.approx([1, 0])
    assert d.wall is not None
    seg = plan.floor(0).walls[d.wall]
    assert seg[:, 0].tolist() == [4, 4]            # the partition the door sits in
    assert sorted(d.jambs[:, 1].tolist()) == [1.0, 2.0]


def test_entrance_heading_points_inside(plan):
    (e,) = plan.entrances
    assert e.door == "front" and e.heading == pytest.approx(0.0)


def test_room_of_inside_and_nearest(plan):
    f = plan.floor(0)
    pts = np.array([[1, 1], [6, 2], [4, 2.5], [9, 1], [-1, 1]], float)
    assert f.room_of(pts).tolist() == [0, 1, 0, -1, -1]    # shared wall -> lower index
    assert f.inside(pts).tolist() == [True, True, True, False, False]
    d, cp, w = f.nearest_wall(np.array([[1.0, 1.0], [4.0, 1.5]]))
    assert d.tolist() == pytest.approx([1.0, 0.5])          # door gap: jamb 0.5 m away
    assert cp[0].tolist() == pytest.approx([0.0, 1.0]) or cp[0].tolist() == pytest.approx([1.0, 0.0])
    assert set(f.walls_near(np.array([4.0, 1.5]), 0.6).tolist()) == {
        i for i, s in enumerate(f.walls) if np.allclose(s[:, 0], 4)}


def test_door_crossings_along_a_path(plan):
    f = plan.floor(0)
    path = np.array([[-1, 1.5], [1, 1.5], [3, 1.4], [5, 1.6], [6, 1.5], [3, 1.5], [3, 2.5]])
    got = f.door_crossings(path)
    assert got == [(0, "front", 1), (2, "dAB0", 1), (4, "dAB0", -1)]
    # Stepping exactly onto the door line and on: one crossing, at the step that reaches it.
    assert f.door_crossings(np.array([[3.0, 1.5], [4.0, 1.5], [5.0, 1.5]])) == [(0, "dAB0", 1)]
    # Passing beside the door (through the wall) is no door crossing.
    assert f.door_crossings(np.array([[3.0, 2.5], [5.0, 2.5]])) == []


def test_sample_free_is_uniform_inside(plan):
    rng = np.random.default_rng(3)
    pts = plan.floor(0).sample_free(20000, rng)
    assert pts.shape == (20000, 2)
    assert plan.floor(0).inside(pts).all()
    # Both rooms have equal area: half the samples in each (5 sigma of a binomial).
    frac_a = np.mean(pts[:, 0] < 4)
    assert abs(frac_a - 0.5) < 5 * math.sqrt(0.25 / 20000)


def test_floors_stairs_and_floor_of_z():
    b = two_rooms(levels=3).build()
    assert [f.z for f in b.floors] == [0, 3, 6]
    assert b.floor_of_z(0.2) == 0 and b.floor_of_z(1.6) == 1 and b.floor_of_z(-2) == 0
    assert b.floor_of_z(np.array([2.9, 4.4, 4.6, 20])).tolist() == [1, 1, 2, 2]
    s = b.floor(0).stairs[0]
    assert (s.floor_from, s.floor_to, s.rise) == (0, 1, 3.0)
    assert s.n_steps == 15 and s.step_height == pytest.approx(0.2)   # 20 cm nominal
    assert s.direction.tolist() == [1, 0] and s.length == pytest.approx(2.5)
    np.testing.assert_allclose(s.position_at([0, 0.5, 1]), [[5, 0.6, 0], [6.25, 0.6, 1.5], [7.5, 0.6, 3]])
    assert s.polygon.area == pytest.approx(2.5)
    with pytest.raises(IndexError, match="floors 0..2"):
        b.floor(3)


def test_georef_round_trip_and_bearing():
    g = GeoRef(lat=46.5191, lon=6.5668, bearing=90.0)
    xy = np.array([[0.0, 0.0], [0.0, 100.0], [250.0, -40.0]])
    ll = g.to_lonlat(xy)
    assert ll[0].tolist() == pytest.approx([6.5668, 46.5191])
    # Bearing 90: plan +y points east, so 100 m of +y is 100 m east (the latitude of the
    # tangent plane's point drops by under a millimetre as the Earth curves away).
    assert ll[1, 1] == pytest.approx(46.5191, abs=1e-8)
    metres_per_deg_lon = 111_320 * math.cos(math.radians(46.5191))
    assert (ll[1, 0] - 6.5668) * metres_per_deg_lon == pytest.approx(100.0, rel=3e-3)
    np.testing.assert_allclose(g.from_lonlat(ll), xy, atol=1e-6)
    assert g.heading_to_azimuth(math.pi / 2) == pytest.approx(math.pi / 2)   # plan north -> east
    with pytest.raises(ValueError, match="lat"):
        GeoRef(lat=95.0, lon=0.0)


def test_georef_placed_at_a_plan_point():
    g = GeoRef.at_point((10.0, 20.0), lat=50.0, lon=8.0, bearing=30.0)
    np.testing.assert_allclose(g.to_lonlat(np.array([[10.0, 20.0]]))[0], [8.0, 50.0], atol=1e-9)


def test_bundled_plan_queries_run_on_every_floor():
    b = load_building(bundled_plan("three_storey"))
    for f in b.floors:
        rng = np.random.default_rng(f.index)
        pts = f.sample_free(500, rng)
        assert (f.room_of(pts) >= 0).all()          # rooms tile the floor
        assert not f.crosses_wall(pts, pts + 1e-3 * (f.nearest_wall(pts)[1] - pts)).any()


def test_building_errors():
    sk = two_rooms()
    sk.anchor("base", (0, 0))                      # duplicate id
    with pytest.raises(BuildingError, match="duplicate id 'base'"):
        sk.build()


def test_first_wall_hit_on_a_floor(plan):
    f = plan.floor(0)
    # From room A east through the partition (x = 4) and on through the east wall (x = 8).
    hit, frac, wall = f.first_wall_hit(np.array([[1.0, 2.5], [1.0, 1.5]]), np.array([[9.0, 2.5], [9.0, 1.5]]))
    assert hit.tolist() == [True, True]
    assert frac.tolist() == pytest.approx([3 / 8, 7 / 8])      # partition; then, via the door, the east wall
    assert f.walls[wall[0]][:, 0].tolist() == [4, 4] and f.walls[wall[1]][:, 0].tolist() == [8, 8]


def test_door_crossings_match_a_naive_scan():
    """Random walks through flat_125 against an independent per-step, per-door scan."""
    from shapely.geometry import LineString
    b = load_building(bundled_plan("flat_125"))
    f = b.floor(0)
    rng = np.random.default_rng(7)
    path = np.cumsum(rng.normal(0, 0.8, (1000, 2)), axis=0) % [12.5, 10.0]
    path = np.repeat(path, 2, axis=0)[1:]            # also zero-length steps
    expected = []
    for i in range(len(path) - 1):
        step = LineString(path[i:i + 2]) if not np.allclose(path[i], path[i + 1]) else None
        hits = []
        for d in f.doors:
            sa, sb = (path[i] - d.center) @ d.axis, (path[i + 1] - d.center) @ d.axis
            if step is not None and (sa >= 0) != (sb >= 0) and step.intersects(LineString(d.jambs)):
                hits.append((sa / (sa - sb), d.id, 1 if sb >= 0 else -1))
        expected += [(i, door, sign) for _, door, sign in sorted(hits)]
    got = f.door_crossings(path)
    assert len(expected) > 20
    assert got == expected


def test_stair_flights_split_the_steps_of_a_u_stair_and_climb():
    # Walking line given from the upper end (3 m) down to floor 0: 6 m flight, 2 m
    # landing, 3 m flight seen from the bottom; 18 steps split 6 : 3 -> 12 and 6.
    u = Stair("u", 1, 0, np.array([[2, 3], [2, 0], [0, 0], [0, 6]], float), 1.0, 3.0, 0.0, 18)
    low, high = u.flights()
    for f in (low, high):
        assert (f.id, f.floor_from, f.floor_to, f.width) == ("u", 0, 1, 1.0)
    np.testing.assert_array_equal(low.path, [[0, 6], [0, 0]])
    np.testing.assert_array_equal(high.path, [[2, 0], [2, 3]])
    assert (low.z_from, low.z_to, low.n_steps) == (0.0, 2.0, 12)
    assert (high.z_from, high.z_to, high.n_steps) == (2.0, 3.0, 6)
    assert low.step_height == pytest.approx(1 / 6) and high.step_height == pytest.approx(1 / 6)
    assert (low.length, high.length) == (6.0, 3.0)
    # One or two segments (an L turning on winders): one flight, the stair's own line.
    ell = Stair("l", 0, 1, np.array([[0, 0], [3, 0], [3, 2]], float), 1.2, 0.0, 3.0)
    (only,) = ell.flights()
    np.testing.assert_array_equal(only.path, ell.path)
    assert (only.z_from, only.z_to, only.n_steps, only.length) == (0.0, 3.0, 15, 5.0)
