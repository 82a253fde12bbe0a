"""Pattern comparison (Algorithm 1, §IV-D) and the pseudo-observation likelihood (eq. 2).

:class:`PatternComparison` holds the sub-patterns of a building and, for an odometry
trajectory of length d:

1. rotates it by phi_hat of eq. (1) (:func:`.principal.principal_rotation`);
2. runs ICP against every sub-pattern under the four initial rotations
   0, pi/2, pi, 3pi/2 — one batched call (:func:`.icp.icp_batch`);
3. for each (pattern, rotation), transforms the last odometry point and assigns the
   RMSE to the pattern's first node (left-hand search: the walk ran backwards along
   the pattern) or last node (right-hand search), whichever it lands closer to
   (Algorithm 1, steps 7-12); E_m keeps the minimum over the rotations (step 14).

The result is an :class:`Observations` table of 2K entries (column 1 and 2 of every
E_m, Pos_m and Hea_m stacked), where an entry never chosen has RMSE +inf.

Eq. (2) scores particle i with exp(-E^(i) / sigma^2), where E^(i) belongs to the
observation "whose associated navigation state most closely resembles that of
particle i": among the entries at the node nearest the particle (the "two identical
positions" in Pos_m: a node is the first node of one pattern and the last node of
another; more where sequences share a node), the one whose heading is closest to
the particle's walking direction.

Heading observations. Algorithm 1 gives the left-hand entry the direction in which
the walker *arrives* at p_eta (Hea(eta, 1) = atan2(-dp_eta)), but the right-hand
entry the direction of the step *after* p_{eta+dN} (Hea(eta, 2) = atan2(dp_{eta+dN})).
A particle's heading is the direction it has been walking, so at every corner of a
right-hand walk the particle is 90 deg from both entries of its node and the choice
between them is left to noise; when it picks the entry whose RMSE is +inf the
particle at the true pose is eliminated. ``right_hand_heading="arrival"`` (default)
uses the arrival direction p_{eta+dN} - p_{eta+dN-1} for the right-hand entry too;
``"departure"`` keeps the paper's formula.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy.spatial import cKDTree

from firenav_framework.building.search_patterns import SearchPatterns
from firenav_framework.geometry import wrap_angles

from .icp import icp_batch, pattern_segments
from .principal import principal_rotation

__all__ = ["Observations", "PatternComparison"]

_FOUR = np.arange(4) * (np.pi / 2)


@dataclass(frozen=True)
class Observations:
    """Pseudo-observations from one comparison: 2K entries (pattern k: 2k first, 2k+1 last).

    ``position`` (2K, 2) [m] = Pos_m, ``heading`` (2K,) [rad] = Hea_m (walking
    direction), ``rmse`` (2K,) [m] = E_m (+inf where not chosen), ``floor`` (2K,).
    """

    position: np.ndarray
    heading: np.ndarray
    rmse: np.ndarray
    floor: np.ndarray

    @property
    def any_finite(self) -> bool:
        return bool(np.isfinite(self.rmse).any())


class PatternComparison:
    """Sub-patterns of length ``length_m`` and the machinery to compare odometry with them."""

    def __init__(self, patterns: SearchPatterns, length_m: float = 20.0, *,
                 max_iter: int = 30, tol: float = 1e-4,
                 right_hand_heading: Literal["arrival", "departure"] = "arrival"):
        self.patterns = patterns
        self.sub = patterns.subpatterns(length_m)
        self._segments = pattern_segments(self.sub.points)
        self.max_iter, self.tol = max_iter, tol
        k = len(self.sub)
        self.entry_node = np.empty(2 * k, dtype=np.int64)
        self.entry_node[0::2] = self.sub.first_node
        self.entry_node[1::2] = self.sub.last_node
        self.entry_heading = np.empty(2 * k)
        self.entry_heading[0::2] = self.sub.first_heading
        if right_hand_heading == "arrival":
            d = self.sub.points[:, -1] - self.sub.points[:, -2]
            self.entry_heading[1::2] = np.arctan2(d[:, 1], d[:, 0])
        elif right_hand_heading == "departure":
            self.entry_heading[1::2] = self.sub.last_heading
        else:
            raise ValueError(f"right_hand_heading must be 'arrival' or 'departure', "
                             f"not {right_hand_heading!r}")
        self.entry_floor = np.repeat(self.sub.floor, 2)
        self.entry_position = patterns.nodes[self.entry_node]
        # entries of every node, padded with -1: (n_nodes, max entries per node)
        order = np.argsort(self.entry_node, kind="stable")
        counts = np.bincount(self.entry_node, minlength=len(patterns.nodes))
        width = int(counts.max()) if len(counts) else 0
        self.node_entries = np.full((len(patterns.nodes), max(width, 1)), -1, dtype=np.int64)
        rank = np.arange(len(order)) - np.repeat(np.cumsum(counts) - counts, counts)
        self.node_entries[self.entry_node[order], rank] = order
        # nearest-node lookup per floor, over nodes that carry entries
        self._trees: dict[int, tuple[cKDTree, np.ndarray]] = {}
        for fl in np.unique(self.sub.floor):
            ids = np.flatnonzero((patterns.node_floor == fl) & (counts > 0))
            self._trees[int(fl)] = (cKDTree(patterns.nodes[ids]), ids)
        # candidate layout: pattern k under rotation i is candidate 4k + i
        self._cand_pattern = np.repeat(np.arange(k), 4)
        self._axis = np.array([patterns.angle[int(f)] for f in self.sub.floor])

    def __len__(self) -> int:
        return len(self.sub)

    def compare(self, odo_xy: np.ndarray, patterns: np.ndarray | None = None) -> Observations:
        """Algorithm 1 for the odometry trajectory ``odo_xy`` (P, 2), INS frame [m].

        ``patterns`` (indices of sub-patterns) restricts the ICP to those: the entries of
        every other pattern are left at +inf. Each pattern's entries do not depend on
        the others, so the entries computed are the same as in the full comparison."""
        k = len(self.sub)
        which = np.arange(k) if patterns is None else np.asarray(patterns, dtype=np.int64)
        cand = np.repeat(which, 4)
        axis = self._axis[which]
        init = np.empty(len(cand))
        for a in np.unique(axis):
            phi = principal_rotation(odo_xy, float(a))          # eq. (1)
            sel = np.repeat(axis == a, 4)
            init[sel] = np.tile(phi + _FOUR, int(sel.sum()) // 4)
        rmse, theta, trans, _ = icp_batch(odo_xy, self.sub.points, cand, init,
                                          max_iter=self.max_iter, tol=self.tol,
                                          segments=self._segments)
        last = odo_xy[-1]
        c, s = np.cos(theta), np.sin(theta)
        xt = np.column_stack([c * last[0] - s * last[1], s * last[0] + c * last[1]]) + trans
        pts = self.sub.points[cand]
        d_first = np.hypot(*(xt - pts[:, 0]).T)
        d_last = np.hypot(*(xt - pts[:, -1]).T)
        col = (d_first >= d_last).astype(np.int64)                # 0: first node, 1: last
        e = np.full((k, 4, 2), np.inf)
        e[cand, np.tile(np.arange(4), len(which)), col] = rmse
        emin = e.min(axis=1)                                        # (k, 2): E_m
        return Observations(position=self.entry_position, heading=self.entry_heading,
                            rmse=emin.reshape(-1), floor=self.entry_floor)

    def entries_of(self, xy: np.ndarray, heading: np.ndarray, floor: np.ndarray) -> np.ndarray:
        """The entry of eq. (2) for particles at ``xy`` (N, 2) walking in ``heading`` (N,)
        [rad] on ``floor`` (N,): among the entries at the node nearest the particle, the
        one whose heading is closest; -1 on a floor without patterns. Entry ``j`` belongs
        to sub-pattern ``j // 2``."""
        out = np.full(len(xy), -1, dtype=np.int64)
        for fl, (tree, ids) in self._trees.items():
            on = floor == fl
            if not on.any():
                continue
            _, j = tree.query(xy[on])
            entries = self.node_entries[ids[j]]                     # (n, width)
            valid = entries >= 0
            dh = np.abs(wrap_angles(heading[on, None] - self.entry_heading[entries]))
            dh[~valid] = np.inf
            out[on] = entries[np.arange(len(entries)), np.argmin(dh, axis=1)]
        return out

    @staticmethod
    def rmse_of(obs: Observations, entries: np.ndarray) -> np.ndarray:
        """E^(i) of eq. (2) for the ``entries`` of :meth:`entries_of` (NaN for -1: no
        information)."""
        return np.where(entries >= 0, obs.rmse[np.maximum(entries, 0)], np.nan)

    def associate(self, obs: Observations, xy: np.ndarray, heading: np.ndarray,
                  floor: np.ndarray) -> np.ndarray:
        """E^(i) of eq. (2) for particles at ``xy`` (N, 2) walking in ``heading`` (N,).

        Particles on a floor without patterns get NaN (no information).
        """
        return self.rmse_of(obs, self.entries_of(xy, heading, floor))

    @staticmethod
    def sample(obs: Observations, n: int, sigma: float, rng: np.random.Generator
               ) -> np.ndarray:
        """``n`` entry indices drawn in proportion to exp(-E / sigma^2) (§IV-E)."""
        ok = np.flatnonzero(np.isfinite(obs.rmse))
        logp = -obs.rmse[ok] / sigma ** 2
        w = np.exp(logp - logp.max())
        return ok[rng.choice(len(ok), size=n, p=w / w.sum())]
