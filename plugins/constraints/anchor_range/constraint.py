"""The ``anchor_range`` constraint: UWB ranges to fixed anchors correct the dead-reckoned path.

The ORCA paper (§2.2, §3.1) leaves a UWB anchor at the entrance and uses its range only
to choose a door; its outlook (§5) adds that "each time a firefighter passes near the
anchor, the position is corrected". The range says how far the firefighter is from the
anchor, which no wall constrains along a corridor: there the INS's stride-length error
piles up unseen (strides measured a few per cent short put the path metres behind).

This rule is a small Kalman filter on the error of the corrected position (2-D, ENU): its
covariance grows with every step (``step_sigma`` of the step length, each axis), every
range taken between two steps is an observation of it, at the position interpolated along
the step to the range's time (tag ``tag_height`` above the floor), and the estimated error
is fed back at once as a translation in the update matrix (eq. 8), so it moves this and
every later step. Ranges through a wall of the floor plan (from the estimated position),
from an anchor on another floor (through a slab) or flagged NLOS by the sensor are not
used: their delay only lengthens them; ranges farther off than ``gate`` sigmas are counted
and dropped, except those shorter than the prediction by more than ``relocate_margin`` too:
walls and delays lengthen a range, so ``relocate_after`` of them in a row say the position
itself is wrong (a track that drifted metres while this filter's covariance, which knows
nothing of the heading drift, stayed tight) and move it onto the last one's circle as a
jump, which the estimator widens its covariance by (warning ``anchor_relocation``), through
a wall of the plan or not; a range that itself puts the walker within ``min_distance`` of
the anchor (horizontally, one sigma long) is a fix at the anchor, the disc it allows as its
variance (the bearing is unknown), which brings the filter no lower than that disc;
otherwise within ``min_distance`` of the anchor (from the estimate) a range says little
about direction and is skipped; a range more than ``max_age`` older than the step it falls
in is stale.
"""
from __future__ import annotations

import bisect
import math
from collections import deque
from dataclasses import dataclass, field

import numpy as np

from firenav_framework import PerAgent, Range, param
from firenav_framework.capabilities.odometry_correction import (UNKNOWN_VARIANCE, OdometryStep,
                                                                StepCorrection)
from firenav_framework.geometry import Rigid2D

from ..anchor_ranges import AnchorRangeInput, TagParams
from ..corrections import axes_covariance, correction
from ..segment_hits import FloorWalls

__all__ = ["AnchorRangeConstraint"]

#: Most ranges kept per agent while no step comes to use them (10 minutes at 10 Hz).
MAX_PENDING = 6000


@dataclass
class _Agent:
    pending: deque = field(default_factory=deque)  # (t, anchor id, range, sigma)
    cov: np.ndarray | None = None                  # (2, 2) position error covariance [m^2]
    t: float | None = None                         # time of the last step [s]
    short: int = 0                                 # ranges in a row too short for the position


class AnchorRangeConstraint(AnchorRangeInput):
    """UWB ranges to fixed anchors correct the dead-reckoned position (Kalman filter, translation)."""

    name = "anchor_range"

    class Params(TagParams):
        init_sigma: float = param(0.3, unit="m", gt=0)
        """position uncertainty at the first step (1 sigma, each axis)"""
        step_sigma: float = param(0.05, ge=0)
        """position noise added per step and axis, as a fraction of the step length"""
        model_sigma: float = param(0.15, unit="m", ge=0)
        """range model error added (in quadrature) to each range's own sigma: tag height, body and
        antenna delays, multipath in line of sight"""
        gate: float = param(3.0, gt=0)
        """ranges farther than this many sigmas from the prediction are dropped"""
        min_distance: float = param(1.0, unit="m", ge=0)
        """horizontal distance to the anchor below which a range is a fix at the anchor (when the
        range says so) or not used (when only the estimate is that close)"""
        use_nlos: bool = param(False)
        """use ranges the sensor flags NLOS (with their sigma)"""
        through_walls: bool = param(False)
        """use ranges whose line of sight from the estimated position crosses a wall of the plan"""
        other_floors: bool = param(False)
        """use ranges from an anchor on another floor than the walker's (through a slab, longer
        by a bias the range's sigma does not state)"""
        max_age: float = param(2.0, unit="s", gt=0)
        """ranges older than this when their step comes are dropped"""
        relocate_after: int = param(2, ge=0)
        """this many ranges in a row shorter than the predicted distance by more than ``gate``
        sigmas and ``relocate_margin`` (walls and NLOS lengthen a range on average, so the
        position is wrong) move the position onto the last one's circle, as a jump the
        estimator widens its covariance by; 0: such ranges are dropped as gated"""
        relocate_margin: float = param(2.0, unit="m", ge=0)
        """how much shorter than predicted a range must be to count towards a relocation: more
        than the noise of a range through walls (which the sensor cannot flag)"""

    def __init__(self, params: Params, ctx):
        super().__init__(params, ctx)
        self.agents: PerAgent[_Agent] = PerAgent(lambda agent: _Agent())
        self._walls: FloorWalls | None = None

    def start(self) -> None:
        super().start()
        self._walls = FloorWalls(self._building)

    def reset(self, agent: str) -> None:
        self.agents.reset(agent)

    def take_range(self, msg: Range, anchor: str) -> None:
        if msg.nlos and not self.params.use_nlos:
            self.ctx.count("ranges_nlos")
            return
        me = self.agents[msg.agent]
        # Ranges wait for the step they fall in. Their age counts against the last step,
        # not the newest range: the estimator may hold steps back (dead_reckoning until
        # it is aligned) and deliver them later with their own, older times.
        while me.pending and me.t is not None and me.t - me.pending[0][0] > self.params.max_age:
            me.pending.popleft()            # older than any step still to come can use
            self.ctx.count("ranges_stale")
        if len(me.pending) >= MAX_PENDING:
            me.pending.popleft()            # no step for a long time (standing still)
            self.ctx.count("ranges_stale")
        entry = (msg.t, anchor, msg.range_m, msg.sigma_m)
        if me.pending and msg.t < me.pending[-1][0]:
            self.ctx.count("ranges_out_of_order")      # waits in time order all the same
            me.pending.insert(bisect.bisect_right(me.pending, msg.t, key=lambda e: e[0]), entry)
        else:
            me.pending.append(entry)

    def correct(self, step: OdometryStep) -> StepCorrection | None:
        p = self.params
        me = self.agents[step.agent]
        if me.cov is None:
            me.cov = np.eye(2) * p.init_sigma ** 2
        move = step.proposed[:2] - step.prev[:2]
        me.cov = me.cov + np.eye(2) * (p.step_sigma ** 2 * float(move @ move))
        t0 = step.t - step.dt if me.t is None else me.t
        me.t = step.t
        due = []
        while me.pending and me.pending[0][0] <= step.t:
            due.append(me.pending.popleft())
        if not due:
            return None
        floor_idx = self._building.floor_of_z(step.prev[2])
        tag_z = self._building.floors[floor_idx].z + p.tag_height
        shift = np.zeros(2)
        relocated = False
        info = np.zeros((2, 2))           # what the used ranges know of the position
        for t_r, anchor_id, r, sigma in due:
            if step.t - t_r > p.max_age:
                self.ctx.count("ranges_stale")
                continue
            if not p.other_floors and self._anchors.floors[anchor_id] != floor_idx:
                self.ctx.count("ranges_other_floor")
                continue
            anchor = self._anchors.positions[anchor_id]
            f = 1.0 if step.t <= t0 else min(max((t_r - t0) / (step.t - t0), 0.0), 1.0)
            pos = step.prev[:2] + f * move + shift
            d = pos - anchor[:2]
            horiz = math.hypot(d[0], d[1])
            sigma = math.hypot(sigma, p.model_sigma)
            dz = tag_z - anchor[2]
            # the squared horizontal distance from the anchor the range allows (1 sigma long)
            disc = max((r + sigma) ** 2 - dz * dz, sigma * sigma)
            if disc < p.min_distance ** 2:
                moved, cov = _near_fix(me.cov, -d, disc, p.gate)
                if moved is not None:
                    shift, me.cov, me.short = shift + moved, cov, 0
                    info += np.eye(2) / disc
                    self.ctx.count("ranges_near")
                    continue
            if horiz < p.min_distance:
                self.ctx.count("ranges_too_close")
                continue
            predicted = math.sqrt(horiz * horiz + dz * dz)
            h = d / predicted
            s = float(h @ me.cov @ h) + sigma * sigma
            innovation = r - predicted
            if p.relocate_after and -innovation > max(p.gate * math.sqrt(s), p.relocate_margin):
                me.short += 1
                if me.short < p.relocate_after:
                    self.ctx.count("ranges_short")
                    continue
                # onto the range's circle, along the bearing the estimate has from the anchor
                rh = math.sqrt(max(r * r - dz * dz, 0.0))
                moved = anchor[:2] + d * (rh / horiz) - pos
                shift = shift + moved
                me.cov = me.cov + np.eye(2) * float(moved @ moved)
                relocated = True
                self.ctx.count("ranges_relocated")
                self.ctx.diagnose(t_r, "warning", "anchor_relocation",
                                  f"UWB ranges to {anchor_id} say {step.agent} is within "
                                  f"{r:.1f} m of it, not {predicted:.1f} m: moved "
                                  f"{math.hypot(*moved):.1f} m, the pose widened",
                                  agent=step.agent)
                h = (d + moved) / r          # on the circle now: the range only narrows it
                s = float(h @ me.cov @ h) + sigma * sigma
                innovation = 0.0
            elif not p.through_walls and self._walls.at_z(step.prev[2]).crosses_one(pos, anchor):
                self.ctx.count("ranges_through_walls")
                continue
            elif abs(innovation) > p.gate * math.sqrt(s):
                self.ctx.count("ranges_gated")
                continue
            me.short = 0
            k = me.cov @ h / s
            shift = shift + k * innovation
            me.cov = me.cov - np.outer(k, h @ me.cov)
            info += np.outer(h, h) / (sigma * sigma)
            self.ctx.count("ranges_used")
        if not shift.any():
            return None
        event = "anchor_relocation" if relocated else "anchor_range"
        return correction(step, step.proposed[:2] + shift, update=Rigid2D.translation(shift),
                          jump=relocated, event=event,
                          cov=_seen(me.cov, info, p.model_sigma ** 2), independent=False,
                          explained=True)


def _near_fix(cov: np.ndarray, offset: np.ndarray, disc: float, gate: float
              ) -> tuple[np.ndarray | None, np.ndarray]:
    """A range that puts the walker within ``sqrt(disc)`` [m] of the anchor, seen as a fix
    at the anchor of variance ``disc`` [m^2] on each axis (the bearing is unknown): the
    move (2,) [m] toward the anchor, ``offset`` (2,) [m] away from the estimate, and the
    filter's covariance after it, ``cov`` (2, 2) [m^2] brought down no lower than ``disc``
    (the same disc, range after range, is no new evidence); (None, ``cov``) when the
    anchor is beyond ``gate`` sigmas."""
    s_inv = np.linalg.inv(cov + np.eye(2) * disc)
    if float(offset @ s_inv @ offset) > gate * gate:
        return None, cov
    k = cov @ s_inv
    values, axes = np.linalg.eigh(cov - k @ cov)
    return k @ offset, axes_covariance(axes, np.maximum(values, disc))


def _seen(cov: np.ndarray, info: np.ndarray, floor: float) -> np.ndarray:
    """The filter's covariance (2, 2) [m^2] on the axes the ranges observed (those of
    the information matrix ``info`` (2, 2) [1/m^2]) plus ``floor`` [m^2], the range
    model error that does not average out from range to range (tag height, body and
    antenna delays), never below what the ranges alone know along the axis (the inverse
    of ``info``'s eigenvalue: nearly collinear ranges hardly see across their line);
    :data:`UNKNOWN_VARIANCE` where they see nothing."""
    values, axes = np.linalg.eigh(info)
    seen = values > 1.0 / UNKNOWN_VARIANCE
    alone = 1.0 / np.where(seen, values, 1.0)
    var = np.where(seen, np.maximum(np.einsum("ik,ij,jk->k", axes, cov, axes) + floor, alone),
                   UNKNOWN_VARIANCE)
    return axes_covariance(axes, var)

