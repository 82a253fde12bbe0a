"""The ``wall_follow`` constraint: a straight walk alongside a wall runs parallel to it.

ORCA (§2.2) sees a heading error only when it steers the dead-reckoned path *into* a
wall. A firefighter following a wall (the search tactic of the ORCA paper's Test II) or
a corridor whose INS heading drifts *away* from it leaves it unseen until the path meets
the opposite wall, metres off. This rule reads the evidence from the other side: when
the last ``follow_distance`` metres of the path are straight (no turn, no sideways
excursion beyond ``straightness``), started within ``follow_range`` of a wall and
deviate from its direction by ``min_angle``..``max_angle``, the deviation is taken for
a heading error and the path is rotated parallel to the wall (a rotation in the update
matrix of eq. 8, like ORCA's rotation rule).

The rotation turns about a point ``pivot`` of the way back from the agent to the start
of the run: 0 keeps the agent where it is (only later steps change, as in ORCA's rule);
1 also undoes the sideways drift of the whole run (the walker kept its distance to the
wall); 0.5 undoes half of it, right for a heading error that grew steadily from zero
along the run (a gyro bias drifting with temperature). The agent is not moved across a
wall by it.

Deviations beyond ``max_angle`` are read as walking away from the wall on purpose;
below it, a straight walk at a shallow angle to a wall (crossing a corridor
diagonally) is misread as drift: the rule assumes the walker follows walls and
corridors.

The path is the INS positions mapped with the current update matrix, so corrections
by any rule (this one, ORCA's rotations, the range rule's translations) are seen at
once and never counted twice. After a correction the straight run starts afresh.
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

import numpy as np

from firenav_framework import Angle, Params, PerAgent, param
from firenav_framework.capabilities.odometry_correction import (OdometryCorrection, OdometryStep,
                                                                StepCorrection)
from firenav_framework.geometry import Rigid2D

from ..corrections import correction
from ..segment_hits import FloorWalls
from ..turn_history import TurnHistory

__all__ = ["WallFollowConstraint", "wall_alongside"]


def wall_alongside(a: np.ndarray, b: np.ndarray, walls: np.ndarray, follow_range: float,
                   max_angle: float) -> tuple[float, float] | None:
    """The wall a straight run ``a`` -> ``b`` (2,) [m] follows, as (signed angle [rad]
    from the wall's direction to the run's, in (-pi/2, pi/2]; mean distance [m]).

    Candidates are ``walls`` (K, 2, 2) within ``max_angle`` of the run's direction whose
    line passes within ``follow_range`` of the run's start (its end may have drifted
    farther), on the same side of both ends, and which overlap the run's middle half;
    the nearest wins. None when there is none.
    """
    run = b - a
    length = math.hypot(run[0], run[1])
    if length == 0.0 or not len(walls):
        return None
    e = walls[:, 1] - walls[:, 0]
    elen = np.hypot(e[:, 0], e[:, 1])
    ok = elen > 0
    e, w0, elen = e[ok], walls[ok, 0], elen[ok]
    u = e / elen[:, None]
    # angle from the wall direction to the run, folded to (-pi/2, pi/2]
    ang = np.arctan2(u[:, 0] * run[1] - u[:, 1] * run[0], u[:, 0] * run[0] + u[:, 1] * run[1])
    ang = np.where(ang > math.pi / 2, ang - math.pi, np.where(ang <= -math.pi / 2,
                                                               ang + math.pi, ang))
    ha = u[:, 0] * (a[1] - w0[:, 1]) - u[:, 1] * (a[0] - w0[:, 0])     # signed distances
    hb = u[:, 0] * (b[1] - w0[:, 1]) - u[:, 1] * (b[0] - w0[:, 0])
    mid = 0.5 * (a + b)
    s_mid = (mid[0] - w0[:, 0]) * u[:, 0] + (mid[1] - w0[:, 1]) * u[:, 1]
    half = 0.25 * length * np.abs(np.cos(ang))
    overlap = (s_mid + half >= 0.0) & (s_mid - half <= elen)
    cand = (np.abs(ang) <= max_angle) & (ha * hb > 0) & (np.abs(ha) <= follow_range) \
        & overlap
    if not cand.any():
        return None
    dist = 0.5 * (np.abs(ha) + np.abs(hb))
    k = np.flatnonzero(cand)[np.argmin(dist[cand])]
    return float(ang[k]), float(dist[k])


@dataclass
class _Run:
    ins: deque = field(default_factory=deque)       # INS-frame positions (2,) of the run
    length: float = 0.0                              # path length of the run [m]
    turns: TurnHistory = field(default_factory=TurnHistory)


class WallFollowConstraint(OdometryCorrection):
    """Wall-following evidence: a straight run alongside a wall is made parallel to it (heading)."""

    name = "wall_follow"
    needs_building = True

    class Params(Params):
        follow_distance: float = param(3.0, unit="m", gt=0)
        """straight path length before its direction is compared with the wall's"""
        max_distance: float = param(15.0, unit="m", gt=0)
        """longest run kept: older steps drop out (a slow drift shows over a long straight walk;
        bounds the memory and the cost)"""
        follow_range: float = param(2.0, unit="m", gt=0)
        """the run starts this close to the wall's line (2 m: any corridor up to 4 m wide)"""
        straightness: float = param(0.25, unit="m", gt=0)
        """largest sideways deviation of the run from its chord"""
        min_angle: Angle = param(math.radians(0.5), unit="rad", ge=0)
        """smaller deviations from the wall's direction are left alone"""
        max_angle: Angle = param(math.radians(8.0), unit="rad", gt=0)
        """larger deviations are walking away from the wall, not drift"""
        pivot: float = param(0.5, ge=0, le=1)
        """the rotation turns about the point this fraction of the way back from the agent to the
        run's start"""
        turn: Angle = param(math.radians(30.0), unit="rad", gt=0)
        """a heading or step-direction change over two steps above this ends the run"""
        min_step: float = param(0.2, unit="m", ge=0)
        """shorter moves have no direction (for the turn check)"""

    def __init__(self, params: Params, ctx):
        super().__init__(params, ctx)
        self.runs: PerAgent[_Run] = PerAgent(lambda agent: _Run())
        self._walls: FloorWalls | None = None

    def start(self) -> None:
        self._walls = FloorWalls(self.ctx.building)

    def reset(self, agent: str) -> None:
        self.runs.reset(agent)

    def correct(self, step: OdometryStep) -> StepCorrection | None:
        p = self.params
        run = self.runs[step.agent]
        ins = np.asarray(step.ins_position[:2], float)
        turn = run.turns.update(step.odometry.delta, step.odometry.dheading, p.min_step)
        if turn > p.turn or not run.ins:
            self._restart(run, ins)
            return None
        run.length += math.hypot(ins[0] - run.ins[-1][0], ins[1] - run.ins[-1][1])
        run.ins.append(ins)
        self._trim(run, max(p.max_distance, p.follow_distance))
        if run.length < p.follow_distance:
            return None
        pts = step.transform.apply(np.array(run.ins))
        a, b = pts[0], pts[-1]
        chord = b - a
        n = math.hypot(chord[0], chord[1])
        side = np.abs((pts[:, 0] - a[0]) * chord[1] - (pts[:, 1] - a[1]) * chord[0]) / max(n, 1e-9)
        if n < 0.8 * p.follow_distance or side.max() > p.straightness:
            # not straight (yet): keep the run as long as a straight tail of it
            self._trim(run, p.follow_distance)
            return None
        walls = self._walls.at_z(step.prev[2])
        near = walls.near(0.5 * (a + b), p.follow_range + 0.5 * n)
        found = wall_alongside(a, b, walls.segments[near], p.follow_range, p.max_angle)
        if found is None or abs(found[0]) < p.min_angle:
            return None
        angle = -found[0]
        self._restart(run, ins)
        pos = step.proposed[:2]
        update = Rigid2D.rotation_about(angle, pos + p.pivot * (a - pos))
        moved = update.apply(pos)
        if p.pivot > 0 and walls.crosses(np.array([step.prev[:2], pos]),
                                         np.array([moved, moved])).any():
            update, moved = Rigid2D.rotation_about(angle, pos), pos
        return correction(step, moved, update=update, event="wall_follow")

    @staticmethod
    def _trim(run: _Run, length: float) -> None:
        """Drop the oldest positions while the run is longer than ``length`` [m]."""
        while len(run.ins) > 2 and run.length > length:
            first = run.ins.popleft()
            run.length -= math.hypot(run.ins[0][0] - first[0], run.ins[0][1] - first[1])

    @staticmethod
    def _restart(run: _Run, ins: np.ndarray) -> None:
        run.ins.clear()
        run.ins.append(ins)
        run.length = 0.0

