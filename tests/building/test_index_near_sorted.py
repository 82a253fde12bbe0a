"""The compiled near-segments query against hand-worked answers and a brute-force scan."""
from __future__ import annotations

import numpy as np
from hypothesis import given, settings, strategies as st

from firenav_framework.building.index import SegmentIndex, segments_near_sorted

# A 10 x 10 m room with a 1 m door gap in its west wall (y 4..5) and a partition at x = 6.
ROOM = np.array([
    [[0, 0], [10, 0]], [[10, 0], [10, 10]], [[10, 10], [0, 10]],
    [[0, 10], [0, 5]], [[0, 4], [0, 0]],
    [[6, 0], [6, 8]],
], dtype=float)


class Query:
    """The query's arguments for one index, with its scratch buffers kept across calls."""

    def __init__(self, index: SegmentIndex):
        self.index = index
        w = max(len(index), 1)
        self.stamp = np.full(w, -1, dtype=np.int64)
        self.out = np.empty(w, dtype=np.int64)
        self.dist2 = np.empty(w)
        self.tag = 0

    def __call__(self, point, radius: float) -> tuple[np.ndarray, np.ndarray]:
        self.tag += 1
        ix = self.index
        start, items = ix.cells
        n = segments_near_sorted(float(point[0]), float(point[1]), float(radius), ix.segments,
                                 start, items, float(ix.origin[0]), float(ix.origin[1]),
                                 ix.cell, ix.shape[0], ix.shape[1], self.stamp, self.tag,
                                 self.out, self.dist2)
        return self.out[:n].copy(), self.dist2[:n].copy()


def test_hand_worked_room():
    q = Query(SegmentIndex(ROOM, cell=1.0))
    # 0.5 m from the partition (5), 3.5 m from the east wall (1), 5 m from south (0) / north (2)
    idx, d2 = q(np.array([6.5, 5.0]), 0.6)
    assert idx.tolist() == [5] and d2.tolist() == [0.25]
    idx, d2 = q(np.array([6.5, 5.0]), 5.0)
    assert idx.tolist() == [5, 1, 0, 2] and d2.tolist() == [0.25, 12.25, 25.0, 25.0]
    # a corner: both walls at the same distance, the lower index first
    idx, d2 = q(np.array([9.5, 9.5]), 0.5)
    assert idx.tolist() == [1, 2] and d2.tolist() == [0.25, 0.25]
    # touching counts (<= radius), as for SegmentIndex.near; outside the grid finds nothing
    assert q(np.array([5.0, 9.0]), 1.0)[0].tolist() == [2]
    assert q(np.array([100.0, 100.0]), 3.0)[0].tolist() == []


def test_empty_index():
    q = Query(SegmentIndex(np.zeros((0, 2, 2))))
    assert q(np.array([0.0, 0.0]), 10.0)[0].tolist() == []


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n_walls=st.integers(1, 150))
def test_equals_near_and_bruteforce(seed, n_walls):
    rng = np.random.default_rng(seed)
    c = rng.uniform(0, 30, (n_walls, 2))
    ang = rng.uniform(0, np.pi, n_walls)
    half = rng.uniform(0.25, 3.0, n_walls)[:, None] * np.column_stack([np.cos(ang), np.sin(ang)])
    segs = np.stack([c - half, c + half], axis=1)
    index = SegmentIndex(segs, cell=float(rng.choice([0.3, 1.0, 2.5])))
    q = Query(index)
    a, e = segs[:, 0], segs[:, 1] - segs[:, 0]
    for _ in range(40):              # one buffer set across many queries (the stamp tags)
        p = rng.uniform(-3, 33, 2)
        radius = float(rng.uniform(0, 6))
        idx, d2 = q(p, radius)
        u = np.clip(((p - a) * e).sum(1) / (e * e).sum(1), 0, 1)
        ref = ((a + u[:, None] * e - p) ** 2).sum(1)
        want = np.flatnonzero(ref <= radius * radius)
        want = want[np.lexsort((want, ref[want]))]
        assert idx.tolist() == want.tolist()
        np.testing.assert_allclose(d2, ref[want], rtol=0, atol=1e-12)
        assert sorted(idx.tolist()) == index.near(p, radius).tolist()
