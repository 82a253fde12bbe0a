"""The ways through a floor's doors, for resets that never cross a wall.

A wrong-compartment reset (ORCA paper, §2.2) moves the agent to the INS position; when
the straight line there crosses a wall, the agent goes by way of the doors instead.
:class:`DoorGraph` holds, per floor, a point just either side of each door (or
doorless opening) and the shortest way between each two of them through clear lines of
sight and the doors (computed once, :func:`scipy.sparse.csgraph.shortest_path`);
:meth:`DoorGraph.way_towards` answers, per reset, the farthest point of the shortest way
from the agent to the INS position that the agent sees.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.sparse.csgraph import shortest_path

from ..segment_hits import SegmentHits
from .doors import DoorTable

__all__ = ["DoorGraph"]


class DoorGraph:
    """Points ``offset`` [m] either side of each door of one floor and the ways between them."""

    def __init__(self, walls: SegmentHits, doors: DoorTable, offset: float) -> None:
        self._walls = walls
        self.nodes = np.concatenate([doors.centers + offset * doors.axes,
                                     doors.centers - offset * doors.axes]).reshape(-1, 2)
        n = len(self.nodes)
        if n == 0:
            self.ways, self.before = np.zeros((0, 0)), np.zeros((0, 0), int)
            return
        a, b = np.repeat(self.nodes, n, axis=0), np.tile(self.nodes, (n, 1))
        clear = ~walls.crosses(a, b)
        links = np.where(clear, np.hypot(*(a - b).T), 0.0).reshape(n, n)
        d = len(doors.centers)
        links[np.arange(d), np.arange(d) + d] = links[np.arange(d) + d, np.arange(d)] = 2 * offset
        np.fill_diagonal(links, 0.0)
        #: (2D, 2D) shortest way [m] node to node (inf: none) ...
        self.ways, before = shortest_path(links, directed=False, return_predecessors=True)
        np.fill_diagonal(before, np.arange(n))
        #: ... and the node before the last on it
        self.before = before

    def way_towards(self, a: np.ndarray, b: np.ndarray, max_detour: float) -> np.ndarray | None:
        """The farthest point (2,) [m] in line of sight of ``a`` along the shortest way from
        ``a`` to ``b`` (2,) [m] through doors (each passed between points just either side
        of it), if that way is at most ``max_detour`` [m] longer than the straight line;
        None otherwise."""
        nodes = self.nodes
        n = len(nodes)
        if n == 0:
            return None
        ends = np.array([a[:2], b[:2]], float)
        near, far = np.repeat(ends, n, axis=0), np.tile(nodes, (2, 1))
        clear = ~self._walls.crosses(near, far).reshape(2, n)
        dist = np.where(clear, np.hypot(*(near - far).T).reshape(2, n), np.inf)
        total = dist[0][:, None] + self.ways + dist[1][None, :]
        i, j = np.unravel_index(int(np.argmin(total)), total.shape)
        if not total[i, j] <= math.hypot(b[0] - a[0], b[1] - a[1]) + max_detour:
            return None
        k = j                                   # back from the last node to the first
        while not clear[0, k]:
            k = self.before[i, k]
        return nodes[k].copy()
