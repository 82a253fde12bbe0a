"""The segment grid index against hand-computed answers, brute force and shapely."""
from __future__ import annotations

import numpy as np
import pytest
import shapely
from hypothesis import given, settings, strategies as st

from firenav_framework.building.index import (ALL, ANY, COUNT, FIRST, SegmentIndex,
                                              segments_hit_bruteforce, segments_hit_walk)

# A 10 x 10 m room with a 1 m door gap in its west wall (y 4..5) and a partition at x = 6.
ROOM = np.array([
    [[0, 0], [10, 0]], [[10, 0], [10, 10]], [[10, 10], [0, 10]],
    [[0, 10], [0, 5]], [[0, 4], [0, 0]],          # west wall with the gap y in (4, 5)
    [[6, 0], [6, 8]],                             # partition, open at the north end
], dtype=float)


@pytest.fixture(scope="module")
def room() -> SegmentIndex:
    return SegmentIndex(ROOM, cell=1.0)


def test_hand_computed_moves(room):
    p0 = np.array([[5, 5], [5, 5], [-1, 4.5], [2, 2], [2, 2], [2, 9], [7, 7], [2, 2]], float)
    p1 = np.array([[5, 9], [5, 10], [1, 4.5], [8, 2], [12, 2], [8, 9], [7, 7], [2, 0]], float)
    #              inside  ends on   door gap  partition  partition+east  over the  still  ends on
    #                      the wall                       wall            partition         a wall
    expected = [False, True, False, True, True, False, False, True]
    assert room.crosses(p0, p1).tolist() == expected


def test_move_crossing_two_walls_reports_the_nearer(room):
    hit, frac, which = room.first_hit(np.array([[2.0, 2.0]]), np.array([[12.0, 2.0]]))
    assert hit[0] and which[0] == 5                 # the partition at x = 6
    assert frac[0] == pytest.approx(0.4)            # (6 - 2) / (12 - 2)
    m, w = room.all_hits(np.array([[2.0, 2.0]]), np.array([[12.0, 2.0]]))
    assert w.tolist() == [1, 5]                     # east wall and partition


def test_touching_cases(room):
    # Starting on a wall, grazing a wall's end point, sliding along a wall: all touch.
    p0 = np.array([[6, 3], [5, 8], [1, 0], [6, 8.5]], float)
    p1 = np.array([[5, 3], [7, 8], [3, 0], [6, 9.5]], float)
    hit, frac, _ = room.first_hit(p0, p1)
    assert hit.tolist() == [True, True, True, False]
    assert frac[:3].tolist() == [0.0, 0.5, 0.0]
    # A jamb end of the door gap touches; the middle of the gap does not.
    assert room.crosses(np.array([[-1, 4.0], [-1, 4.01]]), np.array([[1, 4.0], [1, 4.01]])).tolist() \
        == [True, False]


def test_zero_length_moves(room):
    assert room.crosses(np.array([[6, 3], [5, 5]], float), np.array([[6, 3], [5, 5]], float)).tolist() \
        == [True, False]


def test_empty_and_bad_input(room):
    assert room.crosses(np.empty((0, 2)), np.empty((0, 2))).shape == (0,)
    with pytest.raises(ValueError, match="shape"):
        room.crosses(np.zeros((3, 3)), np.zeros((3, 3)))
    with pytest.raises(ValueError, match="NaN"):
        room.crosses(np.array([[np.nan, 0]]), np.array([[1.0, 0]]))
    empty = SegmentIndex(np.empty((0, 2, 2)))
    assert not empty.crosses(np.array([[0, 0]]), np.array([[1, 1]]))[0]
    assert np.isinf(empty.nearest(np.array([[0.0, 0.0]]))[0][0])


def test_nearest_and_near(room):
    d, cp, w = room.nearest(np.array([[5.0, 9.0], [6.0, 8.5], [-3.0, 4.5], [20.0, 20.0]]))
    assert d.tolist() == pytest.approx([1.0, 0.5, np.hypot(3, 0.5), np.hypot(10, 10)])
    assert cp[0].tolist() == [5.0, 10.0] and w[0] == 2
    assert cp[1].tolist() == [6.0, 8.0] and w[1] == 5
    assert cp[3].tolist() == [10.0, 10.0]
    assert room.near(np.array([6.5, 5.0]), 0.6).tolist() == [5]
    assert room.near(np.array([9.5, 9.5]), 0.5).tolist() == [1, 2]


def random_walls(rng: np.random.Generator, n: int, size: float = 30.0) -> np.ndarray:
    """Axis-aligned and oblique walls of 0.5-6 m, some sharing end points."""
    c = rng.uniform(0, size, (n, 2))
    ang = np.where(rng.random(n) < 0.6, rng.integers(0, 2, n) * np.pi / 2, rng.uniform(0, np.pi, n))
    half = rng.uniform(0.25, 3.0, n)[:, None] * np.column_stack([np.cos(ang), np.sin(ang)])
    segs = np.stack([c - half, c + half], axis=1)
    segs[1::7, 0] = segs[0:-1:7, 1][: len(segs[1::7])]  # some walls chained end to start
    return segs


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n_walls=st.integers(1, 120), step=st.floats(0.05, 8.0))
def test_grid_equals_bruteforce(seed, n_walls, step):
    rng = np.random.default_rng(seed)
    segs = random_walls(rng, n_walls)
    p0 = rng.uniform(-2, 32, (300, 2))
    p1 = p0 + rng.normal(0, step, (300, 2))
    # Snap some moves to end exactly on a wall end point or on a wall's midpoint.
    k = rng.integers(0, n_walls, 40)
    p1[:20] = segs[k[:20], 1]
    p1[20:40] = segs[k[20:], :].mean(axis=1)
    index = SegmentIndex(segs, cell=float(rng.choice([0.3, 1.0, 2.5])))
    hit, frac, which = index.first_hit(p0, p1)
    ref_hit, ref_frac, ref_which = segments_hit_bruteforce(p0, p1, segs)
    assert np.array_equal(hit, ref_hit)
    assert np.array_equal(which, ref_which)
    np.testing.assert_array_equal(frac[hit], ref_frac[hit])
    assert np.array_equal(index.crosses(p0, p1), ref_hit)
    d, _, _ = index.nearest(p0)
    a, e = segs[:, 0], segs[:, 1] - segs[:, 0]
    u = np.clip(np.einsum("nwk,wk->nw", p0[:, None] - a, e) / np.einsum("wk,wk->w", e, e), 0, 1)
    ref_d = np.linalg.norm(a + u[..., None] * e - p0[:, None], axis=2).min(axis=1)
    np.testing.assert_allclose(d, ref_d, rtol=0, atol=1e-12)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_grid_agrees_with_shapely_away_from_touching(seed):
    """An independent predicate (GEOS): equal wherever no move grazes a wall within 1 mm."""
    rng = np.random.default_rng(seed)
    segs = random_walls(rng, 80)
    p0 = rng.uniform(0, 30, (500, 2))
    p1 = p0 + rng.normal(0, 1.5, (500, 2))
    walls = shapely.linestrings(segs)
    moves = shapely.linestrings(np.stack([p0, p1], axis=1))
    tree = shapely.STRtree(walls)
    src, _ = tree.query(moves, predicate="intersects")
    ref = np.zeros(len(p0), dtype=bool)
    ref[src] = True
    near_src, _ = tree.query(moves, predicate="dwithin", distance=1e-3)
    graze = np.zeros(len(p0), dtype=bool)
    graze[near_src] = True
    graze &= ~ref
    ours = SegmentIndex(segs).crosses(p0, p1)
    assert np.array_equal(ours[~graze], ref[~graze])


def test_cells_layout_is_the_documented_csr(room):
    start, items = room.cells
    nx, ny = room.shape
    assert len(start) == nx * ny + 1 and start[-1] == len(items)
    for w, seg in enumerate(ROOM):
        for p in (seg[0], seg.mean(axis=0), seg[1]):
            i, j = ((p - room.origin) // room.cell).astype(int)
            c = j * nx + i
            assert w in items[start[c]:start[c + 1]]


def test_compiled_caller_api_gives_the_brute_force_answers():
    """segments_hit_walk on grid_args() and pad, the way a compiled caller uses them."""
    rng = np.random.default_rng(7)
    segs = random_walls(rng, 60)
    p0 = rng.uniform(-2, 32, (400, 2))
    p1 = p0 + rng.normal(0, 3.0, (400, 2))
    index = SegmentIndex(segs, cell=1.5)
    args = index.grid_args()
    assert args[0] is index.segments and (args[1], args[2]) == index.cells
    assert args[3:] == (*index.origin, index.cell, *index.shape)
    none = np.empty(0, dtype=np.int64)
    frac, which, _ = segments_hit_walk(p0, p1, *args, index.pad, FIRST, none, none, -1)
    ref_hit, ref_frac, ref_which = segments_hit_bruteforce(p0, p1, segs)
    assert ref_hit.any() and not ref_hit.all()
    np.testing.assert_array_equal(which, ref_which)
    np.testing.assert_array_equal(frac[ref_hit], ref_frac[ref_hit])
    any_frac, _, _ = segments_hit_walk(p0, p1, *args, index.pad, ANY, none, none, -1)
    np.testing.assert_array_equal(any_frac >= 0.0, ref_hit)
    n = segments_hit_walk(p0, p1, *args, index.pad, COUNT, none, none, -1)[2]
    out_m, out_w = np.empty(n, dtype=np.int64), np.empty(n, dtype=np.int64)
    segments_hit_walk(p0, p1, *args, index.pad, ALL, out_m, out_w, -1)
    pairs = {(m, w) for m in range(len(p0)) for w in range(len(segs))
             if segments_hit_bruteforce(p0[m:m + 1], p1[m:m + 1], segs[w:w + 1])[0][0]}
    assert set(zip(out_m.tolist(), out_w.tolist())) == pairs and n == len(pairs)
