"""The ``orca`` constraint: ORCA collision-avoidance map matching of dead-reckoned steps.

Implements §2.2 of the ORCA map-matching paper (Algorithm 1, lines 20-24) on the steps
of ``dead_reckoning``. For each step the agent, a disc at its corrected position, would
move to the new INS position (eq. 7 velocity). If that move collides with a wall
(or with a team member, optionally), the ORCA half-planes of the nearby walls give the
set of collision-free velocities (eqs. 3-6, :mod:`.step_solver`), and the paper's rules
read the angle at which the step meets the wall it touches first (:mod:`.rules`):

* up to ``max_rotation`` (30 deg): a heading error. ORCA's correction angle theta (the
  smallest rotation of the INS velocity into the collision-free set, Figure 4) is
  stored in the update matrix (eq. 8) when it is at least ``min_rotation`` (2 deg),
  rotating this and every later step about the agent's position;
* within ``door_tolerance`` (15 deg) of 90 deg: the agent went through a door the path
  missed. It is moved to the door in that wall that best fits the UWB range(s) to the
  anchor(s) (:mod:`.doors`; not simply the nearest door), by a translation in the
  update matrix;
* anything else: the wall holds the agent (it moves with the ORCA velocity closest to
  the INS velocity) and no update is stored;
* an implausible lag of the corrected agent behind the INS position: the agent is in
  the wrong compartment and is reset to the INS position, never through a wall: by way
  of the doors between them (one door per step), or, with no way, refused (the hold is
  then marked a jump: map and odometry disagree, ``orca_held_in_doubt``). The paper's test is a speed
  above ``max_speed`` (2.5 m/s, "unnatural for humans") from the agent to the INS
  position (``reset_from: fixed``); a firefighter running at 3 m/s trips it on every
  step. ``reset_from: ins_speed`` (the default) asks instead whether that speed exceeds
  the speed the INS measured for the step by more than ``reset_margin`` plus
  ``reset_gate`` sigmas of the step's own uncertainty: the lag must come from the map
  correction, not from running; a step that a rule would leave so far behind the INS
  is reset at once (a long step while running that cuts a corner or a door).

For a sliding contact theta equals that angle; near a wall's end (a door jamb) ORCA can
slip past the end with a small rotation although the step ran square into the wall,
which is why the rule is read on the angle of the step to the wall.

Guards, not in the paper, keep position errors from being taken for heading errors or
doors (each can be switched off; docs/orca.md shows what each one buys):

* ``turn_guard``: no rotation is stored during a turn (a heading change or a change of
  step direction over the last two steps), where a stride rounding a corner runs into
  the wall although the heading is fine; the lateral offset of such a shallow contact
  (up to ``max_rotation``) is absorbed by a translation instead. A turn square into a
  wall is only held: translating the path with the agent there would hide a wrong
  compartment from the reset rule;
* ``door_range_gate``: a door is only taken if its expected range to the anchor(s)
  fits the measured one (the nearest door at the end of a corridor is often no door
  the firefighter went through); with ``door_needs_range`` no door is taken without
  a fresh range, since a walker overshooting a room's corner hits the wall square too;
  a door the track really missed is caught by the reset rule;
* ``door_pass``: a step whose line goes through a doorway while the disc clips a jamb
  is centred in the door rather than slid past the jamb;
* ``min_step``: a move shorter than this (a shuffle while standing at a check point)
  is only held at the wall; its direction means nothing.

With ``avoid_team`` the firefighters are ORCA agents among themselves (reciprocal
half-planes, each other's latest position extrapolated to the step time): a step that
only a team member is in the way of is deflected, never read as a heading error or a
door. Meant for firefighters moving independently; a team holding on to each other
(following a step behind) is in constant "collision" and should leave it off.

Every step that no jump moved reports what the walls around the corrected position know
of it (``free_space_covariance``): along and across the heading the walker is somewhere
between the first walls either side (a corridor's width, a room's extent);
``dead_reckoning`` fuses that into its covariance as evidence that repeats from step to
step (never tighter than the extent says), on an axis only where the estimator's own
covariance puts the walker between those walls with at least ``free_space_confidence``:
after a jump or a contradiction widened it, the walls of a room the track may wrongly be
in do not shrink it back.

``rotation_from: heading`` stores the rotation of the INS velocity along its heading
rather than of the step (which sways from stride to stride).

Ranges come from the constraint's own input (``Range`` messages, e.g. the ``uwb``
sensor's ``range`` port); the anchors' positions from the building. A range taken
``age`` seconds before the step is used with its sigma widened by the distance the INS
says the agent moved meanwhile (``speed * age``), so a range stays useful while running
as long as it is not older than ``range_max_age``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np

from firenav_framework import Angle, PerAgent, Range, param
from firenav_framework.building import Floor
from firenav_framework.capabilities.odometry_correction import OdometryStep, StepCorrection
from firenav_framework.geometry import Rigid2D

from ..anchor_ranges import AnchorRangeInput, TagParams
from ..corrections import correction
from ..segment_hits import SegmentHits
from ..turn_history import TurnHistory
from .compartment import CompartmentDoubt
from .door_graph import DoorGraph
from .doors import DoorTable, RangeFix
from .free_space import free_space_covariance
from .rules import approach_angle, classify_rotation, line_crossing
from .step_solver import FREE, WallGrid

__all__ = ["OrcaConstraint"]

#: Most team members an agent avoids at once (the nearest are not chosen: all recent ones
#: up to this many, in name order).
MAX_TEAM = 64


@dataclass
class _Agent:
    ranges: dict[str, tuple[float, float, float]] = field(default_factory=dict)  # anchor -> (t, r, sigma)
    start: np.ndarray | None = None         # last step: corrected start (3,) ...
    end: np.ndarray | None = None           # ... and end (3,) [m]
    dt: float = 1.0                         # ... its duration [s]
    t: float | None = None                  # ... and time [s]
    turns: TurnHistory = field(default_factory=TurnHistory)
    refused: bool = False                   # this step's reset was refused
    held_since: float | None = None         # start [s] of the hold since a refused reset
    doubt: CompartmentDoubt | None = None   # which compartment, from odometry and ranges only
    new_ranges: list[tuple[str, float, bool]] = field(default_factory=list)  # (anchor id, sigma, nlos) since the last step


@dataclass(frozen=True)
class _FloorTables:
    """One floor: its walls as the ORCA kernel's grid and for the per-step wall queries,
    its doors as arrays and the ways through them."""

    floor: Floor
    grid: WallGrid
    walls: SegmentHits
    doors: DoorTable
    door_graph: DoorGraph


class OrcaConstraint(AnchorRangeInput):
    """ORCA collision-avoidance velocity map matching of dead-reckoned steps (rotation, door, reset rules)."""

    name = "orca"

    class Params(TagParams):
        radius: float = param(0.25, unit="m", gt=0)
        """agent disc radius r_n (the paper does not state its value)"""
        time_horizon: float = param(2.0, unit="s", gt=0)
        """obstacle time horizon tau of the velocity obstacle (eq. 3); never below the step
        duration"""
        min_rotation: Angle = param(math.radians(2.0), unit="rad", ge=0)
        """smallest correction stored in the update matrix (2 deg, §2.2)"""
        max_rotation: Angle = param(math.radians(30.0), unit="rad", gt=0)
        """largest correction taken as a heading error (30 deg, §2.2)"""
        door_angle: Angle = param(math.radians(90.0), unit="rad", gt=0)
        """correction angle that means a missed door (90 deg, §2.2)"""
        door_tolerance: Angle = param(math.radians(15.0), unit="rad", ge=0)
        """+- band around door_angle (15 deg, §2.2)"""
        max_speed: float = param(2.5, unit="m/s", gt=0)
        """speed between the corrected and the INS position above which the agent is in the wrong
        compartment and is reset ("unnatural for humans", §2.2; reset_from: fixed)"""
        reset_from: Literal["fixed", "ins_speed"] = param("ins_speed")
        """wrong-compartment test: 'fixed' = speed from the agent to the INS position above
        max_speed (§2.2); 'ins_speed' = that speed above the INS's own speed for the step by
        more than reset_margin + reset_gate sigma"""
        reset_margin: float = param(1.3, unit="m/s", ge=0)
        """lag speed beyond the INS's speed that is implausible (ins_speed test)"""
        reset_gate: float = param(3.0, ge=0)
        """sigmas of the INS step's own uncertainty added to the margin (ins_speed test)"""
        reset_way: Literal["doors", "straight"] = param("doors")
        """how a reset reaches the INS position: 'doors' = never through a wall (by way of the
        doors, else refused); 'straight' = straight there, through walls if need be (§2.2 as
        published)"""
        reset_max_detour: float = param(12.0, unit="m", ge=0)
        """a reset whose straight move crosses a wall goes by way of doors only if that way is at
        most this much longer; else it is refused"""
        door_search_radius: float = param(4.0, unit="m", gt=0)
        """doors farther than this from the agent are not candidates"""
        door_line_tolerance: float = param(0.3, unit="m", gt=0)
        """a candidate door's centre lies this close to the line of the wall the step ran into"""
        door_range_gate: float = param(2.0, unit="m", gt=0)
        """a door is taken only if its expected range to each anchor is within this of the measured
        range (plus 3 sigma)"""
        door_needs_range: bool = param(True)
        """the missed-door rule fires only with a fresh range to an anchor: without one a square
        hit is as likely a walker overshooting a room's corner, and a door the track really
        missed is caught by the reset rule"""
        turn_guard: Angle | None = param(math.radians(30.0), unit="rad", gt=0)
        """no rotation is stored while the INS heading or the step direction turned more than this
        over the last two steps (null: off)"""
        rotation_from: Literal["step", "heading"] = param("step")
        """velocity whose ORCA rotation is stored: 'step' = the step from the agent to the INS
        position (eq. 7, Figure 4); 'heading' = the same speed along the INS heading, which
        ignores the sway of single strides"""
        door_pass: bool = param(True)
        """a step whose line passes through a doorway while the disc clips a jamb is centred in the
        door (a translation) instead of being held or rotated"""
        min_step: float = param(0.2, unit="m", ge=0)
        """a shorter move (a shuffle while standing) is only held at the wall: its direction says
        nothing about heading or doors"""
        range_max_age: float = param(2.0, unit="s", gt=0)
        """ranges older than this are not used to choose a door"""
        free_space_covariance: bool = param(True)
        """every step not moved by a jump reports what the walls around it know of the position
        (along and across the heading: somewhere between the walls either side), fused by
        dead_reckoning into its covariance"""
        free_space_reach: float = param(10.0, unit="m", gt=0)
        """an axis with no wall within this on either side says nothing of the position"""
        free_space_confidence: float = param(0.5, ge=0, le=1)
        """the walls either side hold the position on an axis only if the estimator's covariance
        puts the walker between them with at least this probability (else it may be in another
        compartment)"""
        compartment_growth: float = param(0.05, unit="m/m", ge=0)
        """the sigma of which compartment the walker is in grows by this per metre walked
        when no range narrows it (the INS's drift); the walls hold the position on an axis
        only if that doubt, added to the estimator's covariance, still puts the walker
        between them (free_space_confidence). 0: the estimator's covariance alone"""
        avoid_team: bool = param(False)
        """team members are ORCA agents that avoid each other (reciprocal lines, §2.2)"""
        team_time_horizon: float = param(2.0, unit="s", gt=0)
        """time horizon for agent-agent avoidance"""
        team_max_age: float = param(2.0, unit="s", gt=0)
        """team members not updated for this long are ignored"""

    def __init__(self, params: Params, ctx):
        super().__init__(params, ctx)
        self.agents: PerAgent[_Agent] = PerAgent(lambda agent: _Agent())
        self._floors: dict[int, _FloorTables] = {}

    def start(self) -> None:
        super().start()
        self._no_team = (np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0))

    def reset(self, agent: str) -> None:
        self.agents.reset(agent)

    # -- ranges ---------------------------------------------------------------------
    def take_range(self, msg: Range, anchor: str) -> None:
        me = self.agents[msg.agent]
        me.ranges[anchor] = (msg.t, msg.range_m, msg.sigma_m)
        me.new_ranges.append((anchor, msg.sigma_m, msg.nlos))

    def _fresh_ranges(self, agent: _Agent, t: float, speed: float) -> list[RangeFix]:
        """Ranges no older than ``range_max_age`` at time ``t`` [s], each sigma widened by
        the distance moved since at ``speed`` [m/s]."""
        return [RangeFix(self._anchors.positions[a], r, math.hypot(s, speed * abs(t - tr)))
                for a, (tr, r, s) in sorted(agent.ranges.items())
                if abs(t - tr) <= self.params.range_max_age]

    def _implausible_lag(self, step: OdometryStep) -> bool:
        """The wrong-compartment test (§2.2): the corrected agent, before the step, lags
        implausibly far behind the INS position after it."""
        p = self.params
        lag = math.hypot(step.proposed[0] - step.prev[0], step.proposed[1] - step.prev[1])
        if p.reset_from == "fixed":
            return lag > p.max_speed * step.dt
        odo = step.odometry
        return lag > math.hypot(odo.delta[0], odo.delta[1]) + self._lag_allowance(step)

    def _left_behind(self, step: OdometryStep, fix: StepCorrection) -> bool:
        """``ins_speed`` test only: would the rule's answer leave the agent lagging the
        INS position (moved by the answer's update) by more than the next step can
        plausibly catch up?"""
        if self.params.reset_from == "fixed":
            return False
        target = step.proposed[:2] if fix.update is None else fix.update.apply(step.proposed[:2])
        lag = math.hypot(target[0] - fix.position[0], target[1] - fix.position[1])
        return lag > self._lag_allowance(step)

    def _lag_allowance(self, step: OdometryStep) -> float:
        """Lag [m] beyond the INS's own step that is plausible: the margin speed over the
        step's duration plus ``reset_gate`` sigmas of the step's uncertainty."""
        cov = step.odometry.cov
        sigma = math.sqrt(max(float(cov[0, 0] + cov[1, 1]), 0.0))
        return self.params.reset_margin * step.dt + self.params.reset_gate * sigma

    # -- the odometry_correction protocol ----------------------------------------------
    def correct(self, step: OdometryStep) -> StepCorrection | None:
        me = self.agents[step.agent]
        me.refused = False
        self._update_doubt(me, step)
        fix = self._rules(me, step)
        if fix is not None and not fix.event.startswith("orca_reset") and \
                self._left_behind(step, fix):
            # where the rule would leave the agent it lags the INS implausibly (a long
            # step while running, cutting a corner or a door): the reset rule's answer,
            # one step sooner (kept if the reset is refused)
            fix = self._reset(step, me) or fix
        if me.refused:
            fix = self._held_in_doubt(me, step, fix)
        elif me.held_since is not None:
            me.held_since = None
        return self._record(me, step, self._with_free_space(me, step, fix))

    def _update_doubt(self, me: _Agent, step: OdometryStep) -> None:
        """Widen the compartment doubt by the step's odometry, then narrow it by the
        ranges taken since the last step (tag above the floor of ``prev``) that reach the
        anchor in line of sight: on its floor, not flagged NLOS, no wall of the plan
        between ``prev`` and the anchor. A range through walls or a slab is longer by an
        unknown bias (metres through a floor) that its sigma does not state: it would
        narrow the doubt on evidence it does not hold."""
        if me.doubt is None:
            me.doubt = CompartmentDoubt(self.params.compartment_growth)
        delta = step.odometry.delta
        me.doubt.walk(math.hypot(delta[0], delta[1]))
        floor_idx = self._building.floor_of_z(step.prev[2])
        here = self._tables(floor_idx)
        tag = np.array([step.prev[0], step.prev[1], here.floor.z + self.params.tag_height])
        for anchor, sigma, nlos in me.new_ranges:
            position = self._anchors.positions[anchor]
            if nlos or self._anchors.floors[anchor] != floor_idx or \
                    here.walls.crosses_one(tag[:2], position[:2]):
                continue
            me.doubt.range_to(tag, position, sigma)
        me.new_ranges.clear()

    def _held_in_doubt(self, me: _Agent, step: OdometryStep, fix: StepCorrection | None
                       ) -> StepCorrection:
        """A refused reset: the walls hold the agent while the INS says it is in another
        compartment. The map and the odometry contradict each other and nothing here says
        which is right, so the step is marked a jump: ``dead_reckoning`` widens its
        covariance by the step it did not take and fuses no evidence of the walls (whose
        compartment is in doubt). The first step of such a hold is reported with its place."""
        if me.held_since is None:
            me.held_since = step.t
            lag = math.hypot(step.proposed[0] - step.prev[0], step.proposed[1] - step.prev[1])
            self.ctx.diagnose(step.t, "warning", "orca_held_in_doubt",
                              f"{step.agent} held by the walls at ({step.prev[0]:.1f}, "
                              f"{step.prev[1]:.1f}) m while the INS puts it {lag:.1f} m away "
                              "with no way through doors: map and odometry disagree, the "
                              "pose is widened and not trusted", agent=step.agent)
        if fix is None:
            return StepCorrection(position=step.proposed.copy(), jump=True, event="orca_held")
        return replace(fix, jump=True)

    def _rules(self, me: _Agent, step: OdometryStep) -> StepCorrection | None:
        """The paper's rules and the guards for one step (module docstring)."""
        p = self.params
        turning = self._turning(me, step)
        pos, target = step.prev[:2], step.proposed[:2]
        here = self._tables(self._building.floor_of_z(step.prev[2]))
        if self._implausible_lag(step):
            # Wrong compartment: the agent lags implausibly far behind the INS (§2.2).
            fix = self._reset(step, me)
            if fix is not None:
                return fix
        grid = here.grid
        code, v_orca, theta, wall, frac = grid.step(pos, target, step.dt, p.radius,
                                                    p.time_horizon, p.team_time_horizon,
                                                    *self._team(step))
        if code == FREE:
            return None
        if wall < 0:
            # only team members in the way: avoid them; they say nothing about heading
            return correction(step, pos + step.dt * v_orca, event="orca_team")
        move = target - pos
        if p.door_pass:
            passed = here.doors.passed(pos, target)
            if passed is not None:
                # the step goes through a doorway and the disc only clips a jamb
                k, f = passed
                return self._through_door(step, here, pos, move, f, k, jump=False,
                                          event="orca_door_pass")
        kind = classify_rotation(approach_angle(move, grid.segs[wall]), p.min_rotation,
                                 p.max_rotation, p.door_angle, p.door_tolerance)
        if math.hypot(move[0], move[1]) < p.min_step:
            kind = "blocked"
        if kind == "door":
            fix = self._door(me, step, here, pos, move, wall)
            if fix is not None:
                return fix
            kind = "blocked"
        if turning and kind in ("small", "rotation"):
            # During a turn the step direction is not the walking direction, and a
            # shallow wall contact tells of a position offset rather than a heading
            # error: slide, and move the INS path with the agent so that the offset does
            # not later pass for a heading error or a wrong compartment. (A steeper
            # contact falls through to 'blocked': the reset rule must still see it.)
            moved = pos + step.dt * v_orca
            return correction(step, moved, update=Rigid2D.translation(moved - target),
                              event="orca_turn_slide")
        if kind in ("small", "rotation") and not abs(theta) <= p.max_rotation:
            kind = "blocked"          # a shallow contact no small rotation avoids (a corner)
        if kind == "blocked":
            return correction(step, pos + step.dt * v_orca, event="orca_blocked")
        c, s = math.cos(theta), math.sin(theta)
        moved = np.array([pos[0] + c * move[0] - s * move[1], pos[1] + s * move[0] + c * move[1]])
        stored = theta
        if p.rotation_from == "heading":
            # the same ORCA set, for the INS velocity along its heading instead of the step
            speed = math.hypot(move[0], move[1]) / step.dt
            stored = grid.rotation_for(np.array([speed * math.cos(step.heading),
                                                 speed * math.sin(step.heading)]))
        if not abs(stored) >= p.min_rotation or abs(stored) > p.max_rotation:
            return correction(step, moved, event="orca_small")
        return correction(step, moved, update=Rigid2D.rotation_about(stored, pos),
                          event="orca_rotation")

    def _reset(self, step: OdometryStep, me: _Agent) -> StepCorrection | None:
        """The wrong-compartment reset to the INS position, never through a wall; None
        when it is refused.

        The straight move from the agent to the INS position is checked with the floor's
        segment query. If it crosses a wall, the agent is moved to the first door (or
        opening) of the shortest way there through doors in line of sight of each other
        (``orca_reset_via_door``): the next step carries on from the doorway, and the
        reset rule takes it on if it still lags. With no such way within
        ``reset_max_detour`` of the straight distance the reset is refused
        (``orca_reset_refused``, counted) and the walls hold the agent as on any step,
        the step marked as a jump (:meth:`_held_in_doubt`).
        """
        here = self._tables(self._building.floor_of_z(step.prev[2]))
        pos, target = step.prev[:2], step.proposed[:2]
        if self.params.reset_way == "straight" or not here.walls.crosses_one(pos, target):
            return StepCorrection(position=step.proposed.copy(), jump=True, event="orca_reset")
        via = here.door_graph.way_towards(pos, target, self.params.reset_max_detour)
        if via is None:
            self.ctx.count("orca_reset_refused")
            me.refused = True
            return None
        return correction(step, via, jump=True, event="orca_reset_via_door")

    def _with_free_space(self, me: _Agent, step: OdometryStep, fix: StepCorrection | None
                         ) -> StepCorrection | None:
        """``fix`` (None: the step as proposed) with what the walls around the corrected
        position know of it; jumps (door, reset) are left alone. Whether the walker is
        between those walls is judged on the estimator's covariance plus the compartment
        doubt (:mod:`.compartment`), never on the walls' own evidence."""
        p = self.params
        if not p.free_space_covariance or (fix is not None and fix.jump):
            return fix
        position = step.proposed if fix is None else fix.position
        here = self._tables(self._building.floor_of_z(step.prev[2]))
        prior = None if step.cov is None else step.cov + me.doubt.cov
        cov = free_space_covariance(here.walls, position[:2], step.heading, p.free_space_reach,
                                    prior, p.free_space_confidence)
        if cov is None:
            return fix
        if fix is None:
            return StepCorrection(position=step.proposed.copy(), cov=cov, independent=False)
        return replace(fix, cov=cov, independent=False)

    def _door(self, me: _Agent, step: OdometryStep, here: _FloorTables, pos: np.ndarray,
              move: np.ndarray, wall: int) -> StepCorrection | None:
        """Missed-door rule: translate the path so that it crosses the chosen door."""
        p = self.params
        doors = here.doors
        seg = here.grid.segs[wall]
        f = line_crossing(pos, move, seg)
        crossing = pos + f * move
        odo = step.odometry
        speed = math.hypot(odo.delta[0], odo.delta[1]) / max(odo.t - odo.t_start, 1e-3)
        ranges = self._fresh_ranges(me, step.t, speed)
        if not ranges and p.door_needs_range:
            self.ctx.count("orca_door_no_range")
            return None
        tag_z = here.floor.z + p.tag_height
        k = doors.choose(pos, crossing, move, seg, ranges, tag_z, p.door_search_radius,
                         p.door_line_tolerance)
        if k is None:
            self.ctx.count("orca_door_none")
            return None
        worst = doors.range_misfit(k, ranges, tag_z)
        if worst > p.door_range_gate:
            self.ctx.count("orca_door_range_misfit")
            return None
        return self._through_door(step, here, pos, move, f, k, jump=True, event="orca_door")

    def _through_door(self, step: OdometryStep, here: _FloorTables, pos: np.ndarray,
                      move: np.ndarray, f: float, k: int, jump: bool,
                      event: str) -> StepCorrection:
        """Translate the path so that the step crosses door ``k`` at its centre instead
        of at fraction ``f`` of the step."""
        door = here.doors.centers[k]
        crossing = pos + f * move
        rest = (1.0 - f) * move
        # Cross the door along the step, unless that is blocked or the straight line from
        # the agent to there would pass the jamb: then stop in the doorway (the rest of
        # the step comes with the next one, the update moving it as well), so that the
        # track itself goes through the door.
        end = door + rest
        if here.grid.blocked(door, end, self.params.radius) or here.walls.crosses_one(pos, end):
            end = door.copy()
        return correction(step, end, update=Rigid2D.translation(door - crossing), jump=jump,
                          event=event)

    def _turning(self, me: _Agent, step: OdometryStep) -> bool:
        """Did the walker turn more than ``turn_guard`` over this and the previous step?"""
        turn = me.turns.update(step.odometry.delta, step.odometry.dheading, self.params.min_step)
        return self.params.turn_guard is not None and turn > self.params.turn_guard

    # -- team -------------------------------------------------------------------------
    def _team(self, step: OdometryStep) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Positions (M, 2), velocities (M, 2) and radii (M,) of the other team members."""
        p = self.params
        if not p.avoid_team:
            return self._no_team
        pos, vel = [], []
        for name, other in self.agents.items():
            if name == step.agent or other.t is None or abs(step.t - other.t) > p.team_max_age:
                continue
            if abs(other.end[2] - step.prev[2]) > 1.5:      # not on the same floor
                continue
            v = (other.end[:2] - other.start[:2]) / other.dt
            pos.append(other.end[:2] + v * (step.t - other.t))   # where it is by now
            vel.append(v)
        n = min(len(pos), MAX_TEAM)
        return (np.array(pos[:n], float).reshape(n, 2), np.array(vel[:n], float).reshape(n, 2),
                np.full(n, p.radius))

    def _record(self, me: _Agent, step: OdometryStep, fix: StepCorrection | None
                ) -> StepCorrection | None:
        me.start, me.end = step.prev, (step.proposed if fix is None else fix.position)
        me.dt, me.t = step.dt, step.t
        return fix

    def _tables(self, floor_idx: int) -> _FloorTables:
        """The walls and doors of floor ``floor_idx``, built on its first step."""
        tables = self._floors.get(floor_idx)
        if tables is None:
            floor = self._building.floors[floor_idx]
            walls, doors = SegmentHits(floor.wall_index), DoorTable(floor)
            tables = self._floors[floor_idx] = _FloorTables(
                floor, WallGrid(floor, max_agents=MAX_TEAM), walls, doors,
                DoorGraph(walls, doors, self.params.radius + 0.05))
        return tables

