"""SegmentHits: the building index's compiled walk called directly gives the index's answers."""
from __future__ import annotations

import numpy as np
import pytest

from firenav_framework.building import bundled_plan, load_building
from firenav_plugins.constraints.segment_hits import FloorWalls, SegmentHits


@pytest.fixture(scope="module")
def floor():
    return load_building(bundled_plan("office_loop")).floors[0]


def moves(floor, n=2000, seed=0):
    rng = np.random.default_rng(seed)
    lo, hi = floor.walls.reshape(-1, 2).min(0), floor.walls.reshape(-1, 2).max(0)
    p0 = rng.uniform(lo, hi, (n, 2))
    p1 = p0 + rng.normal(0, 2.0, (n, 2))
    return p0, p1


def test_first_hits_and_crossings_are_the_public_queries_answers(floor):
    p0, p1 = moves(floor)
    hits = SegmentHits(floor.wall_index)
    hit, frac, which = floor.first_wall_hit(p0, p1)
    f, w = hits.first_hit(p0, p1)
    assert hit.any() and not hit.all()
    np.testing.assert_array_equal(w, which)
    np.testing.assert_array_equal(f[hit], frac[hit])
    assert np.all(f[~hit] == -1.0)
    np.testing.assert_array_equal(hits.crosses(p0, p1), floor.crosses_wall(p0, p1))
    assert [hits.crosses_one(a, b) for a, b in zip(p0[:50], p1[:50])] == \
        list(floor.crosses_wall(p0[:50], p1[:50]))


def test_walls_near_a_point_are_the_public_querys(floor):
    p0, _ = moves(floor, n=200, seed=1)
    hits = SegmentHits(floor.wall_index)
    for p, r in zip(p0, np.linspace(0.0, 8.0, len(p0))):
        np.testing.assert_array_equal(hits.near(p, r), floor.walls_near(p, r))


def test_bad_moves_are_refused_with_a_clear_error(floor):
    hits = SegmentHits(floor.wall_index)
    with pytest.raises(ValueError, match="NaN or infinite"):
        hits.crosses(np.array([[0.0, np.nan]]), np.array([[1.0, 1.0]]))
    with pytest.raises(ValueError, match=r"\(N, 2\)"):
        hits.first_hit(np.zeros((2, 3)), np.zeros((2, 3)))
    with pytest.raises(ValueError, match="finite point"):
        hits.near(np.array([np.inf, 0.0]), 1.0)


def test_floor_walls_are_those_of_the_floor_at_a_height():
    b = load_building(bundled_plan("office_loop"))
    walls = FloorWalls(b)
    assert walls.at_z(b.floors[0].z + 1.0) is walls.at_z(b.floors[0].z)
    np.testing.assert_array_equal(walls.at_z(b.floors[0].z).segments, b.floors[0].walls)
