"""Dead reckoning in the building frame: INS odometry aligned, integrated and corrected.

``dead_reckoning`` turns the step increments of an INS (``Odometry`` in the INS's own
frame, whose yaw and origin are arbitrary) into poses in the building frame:

1. **Alignment** (ORCA map-matching paper, §2.2 eq. 9): the first steps are mapped from
   the INS (local) frame to the building (global) frame by a rotation and translation,
   the *update matrix* of eq. 8. It comes from a known entry pose (parameters, the
   building's entrance, or - for evaluation - the simulator's true pose when the INS
   starts), or from the first straight segment walked along a wall of known direction.
   An entry heading is a walking direction, while a foot INS reports the yaw of its IMU
   (toed out, mounted at an angle): the difference is estimated from the first straight
   steps (``imu_yaw_offset``), so steps are held back until then.
2. **Integration**: each increment moves the INS position in the local frame; the
   update matrix maps it into the building frame (the *proposed* position).
3. **Correction**: every attached constraint (an
   :class:`~firenav_framework.capabilities.odometry_correction.OdometryCorrection`) sees
   the step and may move the corrected position and change the update matrix for this
   and all later steps (ORCA's rotation, door and reset rules); constraints run in
   pipeline order, each seeing the previous one's result.

With no constraints this is the plain "INS alone" baseline in the building frame that
the evaluations of several papers compare against.

Outputs, per step: ``pose`` (PoseEstimate; covariance propagated from the entry
uncertainty and each step's odometry covariance, so it grows with distance and turns)
and ``odometry`` (the corrected increments in the building frame, so map-corrected
odometry can feed a particle filter or EKF downstream; steps moved by a jump rule carry
the jump in their covariance).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from firenav_framework import (Estimator, GroundTruth, Odometry, Params, PerAgent, PoseEstimate,
                               param)
from firenav_framework.capabilities.odometry_correction import (OdometryCorrection, OdometryStep,
                                                                StepCorrection)
from firenav_framework.geometry import Rigid2D, rot2, wrap_angle

__all__ = ["DeadReckoning", "PLUGINS"]


@dataclass
class _AgentState:
    transform: Rigid2D | None = None      # INS frame -> building frame (None: not aligned yet)
    ins: np.ndarray = field(default_factory=lambda: np.zeros(3))   # integrated INS position
    position: np.ndarray | None = None    # corrected building-frame position
    heading: float = 0.0                  # corrected building-frame heading
    cov: np.ndarray | None = None         # (4, 4) over (x, y, z, heading)
    t: float | None = None                # time of the last step output
    last_t: float | None = None           # time of the last odometry accepted
    last_abs: np.ndarray | None = None    # the INS's own absolute position at t
    z0: float = 0.0                       # building-frame height of the INS origin [m]
    yaw_offset: float = 0.0               # walking direction minus INS (IMU) yaw [rad]
    pending: list = field(default_factory=list)   # steps held back until aligned
    truth: list = field(default_factory=list)     # recent (t, x, y, z, heading) until aligned
    warned: set = field(default_factory=set)


class DeadReckoning(Estimator):
    """INS odometry in the building frame (eq. 9 alignment) with optional map corrections."""

    name = "dead_reckoning"
    inputs = (Odometry, GroundTruth)
    outputs = {"pose": PoseEstimate, "odometry": Odometry}
    accepts = (OdometryCorrection,)

    class Params(Params):
        alignment: Literal["entrance", "pose", "first_segment", "truth", "none"] = param(
            "entrance", description="how the INS frame is placed in the building (eq. 9): "
            "'entrance' = the building entrance's position and inward heading; 'pose' = "
            "start_position/start_heading; 'first_segment' = position as 'pose' (or the "
            "entrance), heading from the first straight segment walked along a wall of "
            "direction align_heading; 'truth' = the pose of a GroundTruth input stream when "
            "the INS starts (a surveyed start, for evaluation: the paper's GNSS fix at the "
            "entrance); 'none' = the INS frame is the building frame")
        entrance: str | None = param(None, description="entrance id for 'entrance' "
                                     "alignment (default: the building's first entrance)")
        start_position: tuple[float, float, float] | None = param(
            None, unit="m", description="known entry position (x, y, z), building frame")
        start_heading: float | None = param(
            None, unit="rad", description="known entry heading, building frame")
        start_poses: dict[str, tuple[float, float, float, float]] = param(
            {}, description="per-agent known entry pose (x, y, z [m], heading [rad]); "
            "overrides start_position/start_heading for that agent")
        align_heading: float | None = param(
            None, unit="rad", description="'first_segment': building-frame direction of the "
            "first straight segment (a known wall); default the entry heading")
        align_distance: float = param(3.0, unit="m", gt=0, description="'first_segment': "
                                      "straight distance walked before the heading is fixed")
        align_straightness: float = param(0.3, unit="m", gt=0, description="'first_segment': "
                                          "largest sideways deviation from the chord that "
                                          "still counts as straight")
        imu_yaw_offset: float | None = param(
            None, unit="rad", description="walking direction minus the INS heading (the IMU's "
            "yaw on the boot plus the toe-out angle); null: estimated from the first "
            "yaw_offset_steps straight steps")
        yaw_offset_steps: int = param(6, ge=1, description="straight forward steps used to "
                                      "estimate imu_yaw_offset before aligning")
        start_sigma: float = param(0.3, unit="m", gt=0, description="entry position "
                                   "uncertainty (1 sigma, each horizontal axis)")
        start_sigma_heading: float = param(0.05, unit="rad", gt=0, description="entry "
                                           "heading uncertainty (1 sigma)")
        step_heading_sigma: float = param(0.005, unit="rad", ge=0, description="least heading "
                                          "noise per step in the covariance (INS heading drift "
                                          "its own covariance may leave out)")
        step_length_sigma: float = param(0.01, ge=0, description="least position noise per "
                                         "step and axis, as a fraction of the step length")
        max_bridge_speed: float = param(3.0, unit="m/s", gt=0, description="a gap in the "
                                        "odometry is bridged from the INS's absolute "
                                        "positions only if the implied speed is below this")

    def __init__(self, params: Params, ctx):
        super().__init__(params, ctx)
        self.state: PerAgent[_AgentState] = PerAgent(lambda agent: _AgentState())
        self._floors = None   # the building, when the pipeline has one (for floor indices)

    def start(self) -> None:
        p = self.params
        if p.alignment == "entrance" or (p.alignment == "first_segment"
                                         and p.start_position is None):
            _building(self.ctx)   # fail now, with a clear message, if there is none
        if p.alignment == "pose" and (p.start_position is None or p.start_heading is None) \
                and not p.start_poses:
            raise ValueError("alignment 'pose' needs start_position and start_heading "
                             "(or start_poses per agent)")
        try:
            self._floors = self.ctx.building
        except RuntimeError:
            self._floors = None

    def reset(self, agent: str) -> None:
        self.state.reset(agent)

    # -- input ----------------------------------------------------------------------
    def handle(self, stream: str, msg: Odometry | GroundTruth) -> None:
        if isinstance(msg, GroundTruth):
            self._truth(msg)
            return
        if not isinstance(msg, Odometry):
            return
        st = self.state[msg.agent]
        problem = _odometry_problem(msg)
        if problem:
            self.ctx.count("bad_odometry")
            self._warn_once(st, msg, "bad_odometry", f"odometry step skipped: {problem}")
            return
        if st.last_t is not None and msg.t <= st.last_t:
            self.ctx.count("stale_odometry")
            return
        delta = np.asarray(msg.delta, float).copy()
        if st.last_t is not None and msg.t_start > st.last_t + 1e-6:
            delta = self._bridge(st, msg, delta)
        st.last_t = msg.t
        st.last_abs = np.asarray(msg.position, float).copy()
        if st.transform is None:
            st.pending.append((msg, delta))
            if not self._align(msg.agent, st, final=False):
                return
            pending, st.pending = st.pending, []
            for m, d in pending:
                self._step(st, m, d)
        else:
            self._step(st, msg, delta)

    def finish(self) -> None:
        for agent, st in self.state.items():
            if st.transform is None and st.pending:
                if not self._align(agent, st, final=True):
                    self.ctx.count("unaligned_steps", len(st.pending))
                    self.ctx.diagnose(st.pending[-1][0].t, "error", "not_aligned",
                                      f"{len(st.pending)} steps of {agent} never placed in the "
                                      "building: no ground truth before the INS started",
                                      agent=agent)
                    continue
                pending, st.pending = st.pending, []
                for m, d in pending:
                    self._step(st, m, d)

    def _truth(self, msg: GroundTruth) -> None:
        """Keep the recent true poses of an agent not yet aligned ('truth' alignment)."""
        if self.params.alignment != "truth":
            return
        st = self.state[msg.agent]
        if st.transform is not None or not np.all(np.isfinite(msg.position[:2])):
            return
        st.truth.append((msg.t, *np.asarray(msg.position, float)[:3], msg.heading))
        if st.pending:     # keep what the alignment window needs, from just before it
            t0 = st.pending[0][0].t_start
            while len(st.truth) > 2 and st.truth[1][0] <= t0:
                del st.truth[0]
        elif len(st.truth) > 64:
            del st.truth[:32]
        if st.pending and self._align(msg.agent, st, final=False):
            pending, st.pending = st.pending, []
            for m, d in pending:
                self._step(st, m, d)

    # -- alignment (eq. 9) -------------------------------------------------------------
    def _entry_pose(self, agent: str, t: float, final: bool
                    ) -> tuple[np.ndarray, float | None] | None:
        """Known entry position (3,) [m] and heading [rad] (None if unknown) at time ``t``
        [s]; None when it is not known yet (waiting for ground truth)."""
        p = self.params
        if p.alignment == "truth":
            return _truth_at(self.state[agent].truth, t, final)
        if agent in p.start_poses:
            x, y, z, h = p.start_poses[agent]
            return np.array([x, y, z]), h
        if p.alignment in ("pose", "first_segment") and p.start_position is not None:
            return np.asarray(p.start_position, float), p.start_heading
        if p.alignment == "pose":
            raise ValueError("alignment 'pose' needs start_position and start_heading "
                             "(or start_poses for this agent)")
        building = _building(self.ctx)
        if not building.entrances:
            raise ValueError(f"building {building.name!r} has no entrance: set alignment "
                             "'pose' with start_position/start_heading")
        ent = building.entrances[0]
        if p.entrance is not None:
            ent = next((e for e in building.entrances if e.id == p.entrance), None)
            if ent is None:
                raise ValueError(f"no entrance {p.entrance!r}; the building has "
                                 f"{', '.join(e.id for e in building.entrances)}")
        z = building.floors[ent.floor].z
        return np.array([ent.position[0], ent.position[1], z]), ent.heading

    def _align(self, agent: str, st: _AgentState, final: bool) -> bool:
        """Fix the transform from the entry pose (and the first segment); False: not yet."""
        p = self.params
        first = st.pending[0][0]
        offset = p.imu_yaw_offset
        if offset is None and p.alignment != "none":
            offset = _yaw_offset(st.pending, p.yaw_offset_steps, final)
            if offset is None:
                return False                     # not enough straight steps yet
        st.yaw_offset = offset or 0.0
        # walking direction at the start, in the INS frame
        h_ins0 = wrap_angle(first.heading - first.dheading + st.yaw_offset)
        if p.alignment == "none":
            st.transform = Rigid2D()
            start = np.zeros(3)
        else:
            entry = self._entry_pose(agent, first.t_start, final)
            if entry is None:
                return False
            start, heading = entry
            if p.alignment == "first_segment":
                chord = _straight_chord(np.array([d for _, d in st.pending]),
                                        p.align_straightness)
                target = p.align_heading if p.align_heading is not None else heading
                if target is None:
                    raise ValueError("alignment 'first_segment' needs align_heading or an "
                                     "entry heading")
                length = float(np.hypot(*chord[:2]))
                if length < p.align_distance and not final:
                    walked = sum(float(np.hypot(*d[:2])) for _, d in st.pending)
                    if walked < p.align_distance:   # still walking the first segment
                        return False
                if length < 0.5:
                    self.ctx.diagnose(first.t, "warning", "alignment_fallback",
                                      "no straight first segment: aligned with the entry "
                                      "heading", agent=agent)
                    seg_heading, heading = h_ins0, target
                else:
                    seg_heading, heading = math.atan2(chord[1], chord[0]), target
                st.transform = Rigid2D.mapping(np.zeros(2), seg_heading, start, heading)
            else:
                if heading is None:
                    raise ValueError("the entry heading is unknown: set start_heading")
                st.transform = Rigid2D.mapping(np.zeros(2), h_ins0, start, heading)
        st.ins = np.zeros(3)
        st.position = np.array([*st.transform.apply(np.zeros(2)), start[2]])
        st.heading = wrap_angle(h_ins0 + st.transform.angle)
        st.cov = np.diag([p.start_sigma ** 2, p.start_sigma ** 2, 0.01,
                          p.start_sigma_heading ** 2])
        st.z0 = float(start[2])
        return True

    # -- one step ---------------------------------------------------------------------
    def _step(self, st: _AgentState, msg: Odometry, delta: np.ndarray) -> None:
        dt = msg.t - (st.t if st.t is not None else msg.t_start)
        dt = max(dt, 1e-3)
        prev = st.position.copy()
        st.ins = st.ins + delta
        proposed = np.array([*st.transform.apply(st.ins[:2]), st.z0 + st.ins[2]])
        heading = wrap_angle(msg.heading + st.yaw_offset + st.transform.angle)
        position, jump, dangle = proposed, False, 0.0
        for c in self.constraints:
            step = OdometryStep(agent=msg.agent, t=msg.t, dt=dt, prev=prev, proposed=position,
                                heading=heading, transform=st.transform,
                                ins_position=st.ins.copy(), odometry=msg)
            fix = c.correct(step)
            if fix is None:
                continue
            if fix.event:
                self.ctx.count(fix.event)
            position = np.asarray(fix.position, float)
            jump = jump or fix.jump
            if fix.update is not None:
                st.transform = st.transform.then(fix.update)
                dangle += fix.update.angle
                heading = wrap_angle(heading + fix.update.angle)
        # covariance: heading error carries into position, plus the step's own noise
        move = position - prev
        g = np.eye(4)
        g[:2, :2] = rot2(st.transform.angle)
        f = np.eye(4)
        f[0, 3], f[1, 3] = -move[1], move[0]
        q = g @ np.asarray(msg.cov, float) @ g.T
        # floors for what INS covariances tend to leave out (heading drift, step length)
        length2 = float(delta[:2] @ delta[:2])
        q[3, 3] = max(q[3, 3], self.params.step_heading_sigma ** 2)
        for i in (0, 1):
            q[i, i] = max(q[i, i], self.params.step_length_sigma ** 2 * length2)
        if jump:
            q[:2, :2] += np.eye(2) * float(move[:2] @ move[:2])
        st.cov = f @ st.cov @ f.T + q
        st.position, st.heading, st.t = position, heading, msg.t
        floor = None if self._floors is None else int(self._floors.floor_of_z(position[2]))
        self.ctx.publish("pose", PoseEstimate(
            t=msg.t, agent=msg.agent, device=msg.device, position=position.copy(),
            heading=heading, cov=st.cov.copy(), floor=floor))
        self.ctx.publish("odometry", Odometry(
            t=msg.t, agent=msg.agent, device=msg.device, t_start=msg.t - dt, delta=move,
            dheading=msg.dheading + dangle, cov=q, position=position.copy(),
            heading=heading, motion=msg.motion))

    def _bridge(self, st: _AgentState, msg: Odometry, delta: np.ndarray) -> np.ndarray:
        """Missed odometry before this step: add the INS's own absolute displacement."""
        gap = msg.t_start - st.last_t
        missing = np.asarray(msg.position, float) - delta - st.last_abs
        if np.all(np.isfinite(missing)) and np.hypot(*missing[:2]) <= \
                self.params.max_bridge_speed * gap + 0.5:
            self.ctx.count("gaps_bridged")
            return delta + missing
        self.ctx.count("gaps_unbridged")
        self.ctx.diagnose(msg.t, "warning", "odometry_gap",
                          f"{gap:.1f} s of odometry missing and the INS's absolute position "
                          f"jumped {np.hypot(*missing[:2]):.1f} m: the gap is not bridged",
                          agent=msg.agent)
        return delta

    def _warn_once(self, st: _AgentState, msg: Odometry, code: str, text: str) -> None:
        if code not in st.warned:
            st.warned.add(code)
            self.ctx.diagnose(msg.t, "warning", code, text, agent=msg.agent)


def _odometry_problem(msg: Odometry) -> str:
    """Why an Odometry message cannot be used ('' when it can)."""
    delta = np.asarray(msg.delta, float)
    if delta.shape != (3,):
        return f"delta has shape {delta.shape}, expected (3,)"
    if not np.all(np.isfinite(delta)) or not math.isfinite(msg.dheading):
        return "non-finite increment"
    if not math.isfinite(msg.heading) or not np.all(np.isfinite(msg.position)):
        return "non-finite absolute pose"
    cov = np.asarray(msg.cov, float)
    if not np.all(np.isfinite(cov)) or np.any(np.diag(cov) < 0):
        return "covariance not finite or with negative variances"
    if not msg.t >= msg.t_start:
        return f"interval ends ({msg.t}) before it starts ({msg.t_start})"
    return ""


def _yaw_offset(steps: list, n: int, final: bool) -> float | None:
    """Circular mean of (step direction - INS heading at mid-step) over the first ``n``
    straight forward steps (the previous step straight too: a stride that rounds a
    corner lags the foot's heading): the IMU's yaw on the boot plus the toe-out. None:
    not enough steps yet (0 at the end of input when there are none at all)."""
    diffs, straight_before = [], False
    for msg, delta in steps:
        forward = (np.hypot(*delta[:2]) >= 0.3 and abs(msg.dheading) <= math.radians(5)
                   and msg.motion in ("", "walk"))
        if forward and straight_before:
            diffs.append(math.atan2(delta[1], delta[0]) - (msg.heading - 0.5 * msg.dheading))
        straight_before = forward or (np.hypot(*delta[:2]) < 0.05
                                      and abs(msg.dheading) <= math.radians(5) and straight_before)
        if len(diffs) == n:
            break
    if len(diffs) < n and not final:
        return None
    if not diffs:
        return 0.0
    return math.atan2(np.mean(np.sin(diffs)), np.mean(np.cos(diffs)))


def _straight_chord(deltas: np.ndarray, tolerance: float) -> np.ndarray:
    """Chord (3,) of the longest straight prefix of a path given by its increments.

    The prefix ends where a point strays more than ``tolerance`` [m] sideways from the
    chord from the start to that point's successor.
    """
    pts = np.vstack([np.zeros(3), np.cumsum(deltas, axis=0)])
    best = pts[1] - pts[0] if len(pts) > 1 else np.zeros(3)
    for k in range(2, len(pts)):
        chord = pts[k, :2]
        n = float(np.hypot(*chord))
        if n == 0.0:
            continue
        side = np.abs(pts[1:k, 0] * chord[1] - pts[1:k, 1] * chord[0]) / n
        if np.any(side > tolerance):
            break
        best = pts[k] - pts[0]
    return best


def _truth_at(samples: list, t: float, final: bool) -> tuple[np.ndarray, float | None] | None:
    """The true pose at time ``t`` from (t, x, y, z, heading) samples: the last one at or
    before ``t`` (the first one if all are later), once a later sample shows that no closer
    one will come (or at the end of input)."""
    if not samples or (samples[-1][0] < t and not final):
        return None
    before = [s for s in samples if s[0] <= t]
    _, x, y, z, h = before[-1] if before else samples[0]
    return np.array([x, y, z]), (h if math.isfinite(h) else None)


def _building(ctx):
    try:
        return ctx.building
    except RuntimeError as exc:
        raise ValueError("alignment from the building entrance needs a building: add "
                         "'building:' to the pipeline, use a source that brings one, or "
                         "set alignment 'pose' with start_position/start_heading") from exc


PLUGINS = [DeadReckoning]
