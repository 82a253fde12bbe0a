"""The missed-door rule's choice of door, supported by UWB ranges to fixed anchors.

When the correction angle is about 90 degrees the agent walked through a door the
dead-reckoned path missed (ORCA paper, §2.2). The nearest door is often the wrong one
where doors sit close together, so the paper picks the door that best explains the
measured distance to the anchor left at the entrance. :class:`DoorTable` does that for
any number of anchors: among the doors in the wall the step ran into, near the
crossing, not behind the agent and in its line of sight (a door beyond a partition
wall cannot be the one it just walked through), it minimises the sum of squared
normalised range residuals, and falls back to the nearest door when no fresh range is
known.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from firenav_framework.building.index import SegmentIndex

from ..segment_hits import SegmentHits


@dataclass(frozen=True)
class RangeFix:
    """A recent range [m] (with its sigma [m]) from the agent's tag to an anchor at ``anchor`` (3,)."""

    anchor: np.ndarray
    range_m: float
    sigma_m: float


class DoorTable:
    """Doors and doorless openings of one floor as arrays (centres (D, 2), axes (D, 2))."""

    def __init__(self, floor) -> None:
        gaps = list(floor.doors) + list(floor.openings)
        self._walls = SegmentHits(floor.wall_index)
        self.ids = [g.id for g in gaps]
        self.centers = np.array([g.center for g in gaps], float).reshape(-1, 2)
        self.axes = np.array([g.axis for g in gaps], float).reshape(-1, 2)
        self._gaps = SegmentHits(SegmentIndex(np.array([g.jambs for g in gaps],
                                                       float).reshape(-1, 2, 2)))

    def passed(self, p0: np.ndarray, p1: np.ndarray) -> tuple[int, float] | None:
        """The door whose gap (jamb to jamb) the move ``p0`` -> ``p1`` (2,) [m] crosses
        first, and the fraction of the move there; None when it crosses none."""
        if not len(self):
            return None
        frac, idx = self._gaps.first_hit(np.asarray(p0, float)[None, :2],
                                         np.asarray(p1, float)[None, :2])
        return (int(idx[0]), float(frac[0])) if idx[0] >= 0 else None

    def __len__(self) -> int:
        return len(self.ids)

    def choose(self, agent: np.ndarray, crossing: np.ndarray, direction: np.ndarray,
               wall: np.ndarray, ranges: list[RangeFix], tag_z: float, search_radius: float,
               line_tolerance: float) -> int | None:
        """Index of the door the agent most likely crossed instead of ``wall``, or None.

        ``agent`` (2,) is the agent's position before the step and ``crossing`` (2,)
        where the dead-reckoned step meets the wall [m]; ``direction`` (2,) the step;
        ``wall`` (2, 2) the wall segment it hit. Candidates are doors in line with that
        wall (centre within ``line_tolerance`` [m] of its line), within
        ``search_radius`` [m] of the crossing, not behind the agent and reachable from
        it in a straight line without touching a wall. The expected range from a door
        to an anchor puts the tag at height ``tag_z`` [m].
        """
        if not len(self):
            return None
        e = wall[1] - wall[0]
        length = float(np.hypot(*e))
        if length == 0.0:
            return None
        normal = np.array([-e[1], e[0]]) / length
        off_line = np.abs((self.centers - wall[0]) @ normal)
        dist = np.hypot(*(self.centers - crossing[:2]).T)
        ahead = (self.centers - crossing[:2]) @ direction[:2] >= -line_tolerance * float(
            np.hypot(*direction[:2]))
        cand = np.flatnonzero((off_line <= line_tolerance) & (dist <= search_radius) & ahead)
        if len(cand):
            seen = ~self._walls.crosses(np.repeat(np.asarray(agent, float)[None, :2], len(cand),
                                                  axis=0), self.centers[cand])
            cand = cand[seen]
        if not len(cand):
            return None
        cost = np.zeros(len(cand))
        for fix in ranges:
            cost += (self._residuals(cand, fix, tag_z) / fix.sigma_m) ** 2
        best = np.lexsort((dist[cand], cost))[0]    # least cost, then nearest
        return int(cand[best])

    def range_misfit(self, k: int, ranges: list[RangeFix], tag_z: float) -> float:
        """Largest |expected - measured| range of door ``k`` beyond 3 sigma [m] (0 if none)."""
        worst = 0.0
        for fix in ranges:
            res = abs(float(self._residuals(np.array([k]), fix, tag_z)[0]))
            worst = max(worst, res - 3.0 * fix.sigma_m)
        return worst

    def _residuals(self, idx: np.ndarray, fix: RangeFix, tag_z: float) -> np.ndarray:
        """Expected minus measured range [m] for doors ``idx`` (tag at height ``tag_z``)."""
        dz = tag_z - fix.anchor[2]
        expected = np.sqrt(np.sum((self.centers[idx] - fix.anchor[:2]) ** 2, axis=1) + dz * dz)
        return expected - fix.range_m
