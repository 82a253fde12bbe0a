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
   pipeline order, each seeing the previous one's result. A correction that says what it
   knows of the position (a measurement covariance: across the wall a step touched, along
   the line to a UWB anchor) is fused into the covariance (:mod:`.fusion`), so the
   covariance and the protection radius shrink where the map or the radio hold the track.

With no constraints this is the plain "INS alone" baseline in the building frame that
the evaluations of several papers compare against.

Outputs, per step: ``pose`` (PoseEstimate; covariance propagated from the entry
uncertainty, each step's odometry covariance and two error states the odometry's white
noise leaves out - the heading rate, so the heading error grows with time, and the
step-length scale, so the distance error grows with distance (``drift``) - with the
protection radius and ``trusted`` derived from it, :mod:`firenav_framework.integrity`)
and ``odometry`` (the corrected increments in the building frame, so map-corrected
odometry can feed a particle filter or EKF downstream; steps moved by a jump rule carry
the jump in their covariance).

**Contradiction.** A correction that moves the position further from the odometry's
prediction (the previous position plus the step) than the covariance allows
(``drift.contradiction_gate``, squared Mahalanobis distance) contradicts the odometry: a
diagnostic ``odometry_contradicted`` says where, the pose is not trusted, and the
covariance is widened by the size of the correction, as for every jump (door or reset
rule): the estimate does not hold on to a position its own odometry disagrees with.

**Rule corrections.** A correction within that gate that no measurement explains
(``StepCorrection.explained`` False: walls that hold, slide or turn the step) may be
wrong while the odometry is right (a wrong compartment, a wall the plan lacks). Its move
``m`` (2,) [m] from the odometry's prediction, less the moves of the corrections a
measurement explains, widens the position covariance by ``drift.correction_doubt * m
m^T`` [m^2]: a track the walls hold back step after step stops being trusted as those
moves add up. What the walls know of the position is fused afterwards, as on every step.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from firenav_framework import Estimator, GroundTruth, Odometry, PerAgent, PoseEstimate
from firenav_framework.contract import NoBuilding
from firenav_framework.capabilities.odometry_correction import OdometryCorrection, OdometryStep
from firenav_framework.geometry import Rigid2D, planar_rotation, wrap_angle
from firenav_framework.integrity import gaussian_protection_radius, trusted

from ..odometry_input import accept_odometry
from ..start_pose import entrance_start
from .alignment import imu_yaw_offset, straight_chord, truth_at
from .fusion import fuse_position
from .params import DeadReckoningParams

__all__ = ["DeadReckoningEstimator"]


@dataclass
class _AgentState:
    transform: Rigid2D | None = None      # INS frame -> building frame (None: not aligned yet)
    ins: np.ndarray = field(default_factory=lambda: np.zeros(3))   # integrated INS position
    position: np.ndarray | None = None    # corrected building-frame position
    heading: float = 0.0                  # corrected building-frame heading
    cov: np.ndarray | None = None         # (6, 6): (x, y, z, heading, heading rate, scale)
    t: float | None = None                # time of the last step output
    last_t: float | None = None           # time of the last odometry accepted
    last_abs: np.ndarray | None = None    # the INS's own absolute position at t
    z0: float = 0.0                       # building-frame height of the INS origin [m]
    yaw_offset: float = 0.0               # walking direction minus INS (IMU) yaw [rad]
    pending: list = field(default_factory=list)   # steps held back until aligned
    truth: list = field(default_factory=list)     # recent (t, x, y, z, heading) until aligned


class DeadReckoningEstimator(Estimator):
    """INS odometry in the building frame (eq. 9 alignment) with optional map corrections."""

    name = "dead_reckoning"
    inputs = (Odometry, GroundTruth)
    outputs = {"pose": PoseEstimate, "odometry": Odometry}
    accepts = (OdometryCorrection,)
    Params = DeadReckoningParams

    def __init__(self, params: DeadReckoningParams, ctx):
        super().__init__(params, ctx)
        self.state: PerAgent[_AgentState] = PerAgent(lambda agent: _AgentState())
        self._floors = None   # the building, when the pipeline has one (for floor indices)

    def start(self) -> None:
        start = self.params.start
        if start.mode == "entrance":
            _building(self.ctx)   # fail now, with a clear message, if there is none
        self._floors = self.ctx.building if self.ctx.has_building else None

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
        if not accept_odometry(self.ctx, msg, st.last_t):
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
        if self.params.start.mode != "truth":
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
        start = self.params.start
        if start.mode == "truth":
            return truth_at(self.state[agent].truth, t, final)
        if start.mode == "pose":
            position, heading = start.pose_of(agent)
            return np.asarray(position, float), heading
        position, entrance = entrance_start(_building(self.ctx), start.entrance)
        return position, entrance.heading

    def _align(self, agent: str, st: _AgentState, final: bool) -> bool:
        """Fix the transform from the entry pose (and the first segment); False: not yet."""
        start, first = self.params.start, st.pending[0][0]
        offset = self.params.imu_yaw_offset.angle
        if offset is None and start.mode != "unknown":
            offset = imu_yaw_offset(st.pending, self.params.imu_yaw_offset.steps, final)
            if offset is None:
                return False                     # not enough straight steps yet
        st.yaw_offset = offset or 0.0
        # walking direction at the start, in the INS frame
        h_ins0 = wrap_angle(first.heading - first.dheading + st.yaw_offset)
        if start.mode == "unknown":
            st.transform = Rigid2D()
            position = np.zeros(3)
        else:
            entry = self._entry_pose(agent, first.t_start, final)
            if entry is None:
                return False
            position, heading = entry
            segment = start.first_segment
            if segment is not None:
                chord = straight_chord(np.array([d for _, d in st.pending]), segment.straightness)
                target = segment.wall_heading if segment.wall_heading is not None else heading
                if target is None:
                    raise ValueError("start.first_segment needs wall_heading or a start heading")
                length = float(np.hypot(*chord[:2]))
                if length < segment.distance and not final:
                    walked = sum(float(np.hypot(*d[:2])) for _, d in st.pending)
                    if walked < segment.distance:   # still walking the first segment
                        return False
                if length < 0.5:
                    self.ctx.diagnose(first.t, "warning", "alignment_fallback",
                                      "no straight first segment: aligned with the entry "
                                      "heading", agent=agent)
                    seg_heading, heading = h_ins0, target
                else:
                    seg_heading, heading = math.atan2(chord[1], chord[0]), target
                st.transform = Rigid2D.mapping(np.zeros(2), seg_heading, position, heading)
            else:
                if heading is None:
                    raise ValueError(f"the start heading of {agent} is unknown (no heading in "
                                     "its ground truth): give start.first_segment")
                st.transform = Rigid2D.mapping(np.zeros(2), h_ins0, position, heading)
        st.ins = np.zeros(3)
        st.position = np.array([*st.transform.apply(np.zeros(2)), position[2]])
        st.heading = wrap_angle(h_ins0 + st.transform.angle)
        sp, sh = start.sigma_position, start.sigma_heading
        drift = self.params.drift
        st.cov = np.diag([sp ** 2, sp ** 2, 0.01, sh ** 2, drift.heading_rate_sigma ** 2,
                          drift.scale_sigma ** 2])
        st.z0 = float(position[2])
        return True

    # -- one step ---------------------------------------------------------------------
    def _step(self, st: _AgentState, msg: Odometry, delta: np.ndarray) -> None:
        dt = msg.t - (st.t if st.t is not None else msg.t_start)
        dt = max(dt, 1e-3)
        prev = st.position.copy()
        st.ins = st.ins + delta
        odometry_move = planar_rotation(st.transform.angle, 2) @ delta[:2]
        proposed = np.array([*st.transform.apply(st.ins[:2]), st.z0 + st.ins[2]])
        heading = wrap_angle(msg.heading + st.yaw_offset + st.transform.angle)
        position, jump, dangle = proposed, False, 0.0
        measured = []                     # (cov (2, 2), independent) of the corrections
        explained = np.zeros(2)           # the moves the measurements account for [m]
        for c in self.constraints:
            step = OdometryStep(agent=msg.agent, t=msg.t, dt=dt, prev=prev, proposed=position,
                                heading=heading, transform=st.transform,
                                ins_position=st.ins.copy(), odometry=msg,
                                cov=st.cov[:2, :2].copy())
            fix = c.correct(step)
            if fix is None:
                continue
            if fix.event:
                self.ctx.count(fix.event)
            if fix.explained:
                explained += np.asarray(fix.position, float)[:2] - position[:2]
            position = np.asarray(fix.position, float)
            jump = jump or fix.jump
            if fix.cov is not None:
                measured.append((np.asarray(fix.cov, float), fix.independent))
            if fix.update is not None:
                st.transform = st.transform.then(fix.update)
                dangle += fix.update.angle
                heading = wrap_angle(heading + fix.update.angle)
        move = position - prev
        q = self._step_noise(st, msg, delta)
        # the odometry's heading variance per step, read as a residual rate
        duration = max(msg.t - msg.t_start, 1e-3)
        st.cov[4, 4] = max(st.cov[4, 4], float(msg.cov[3, 3]) / duration ** 2)
        st.cov = _propagate(st.cov, move, dt, q)
        # a correction the odometry cannot explain: say so and widen by it
        off = position[:2] - prev[:2] - odometry_move
        contradicted = self._contradicts(st.cov[:2, :2], off)
        if contradicted:
            self.ctx.count("odometry_contradicted")
            self.ctx.diagnose(msg.t, "warning", "odometry_contradicted",
                              f"a correction moved {msg.agent} {np.hypot(*off):.1f} m from "
                              f"where the odometry puts it, at ({position[0]:.1f}, "
                              f"{position[1]:.1f}) m: the pose is widened and not trusted",
                              agent=msg.agent)
        if jump or contradicted:
            widen = np.eye(2) * float(off @ off)
        else:
            # a rule's correction that no measurement explains may be wrong: the truth
            # may be where the odometry put it, along the move the rule made
            ruled = off - explained
            widen = self.params.drift.correction_doubt * np.outer(ruled, ruled)
        st.cov[:2, :2] += widen
        q[:2, :2] += widen
        if not (jump or contradicted):
            for meas, independent in measured:   # what the map / radio know of the position
                st.cov = fuse_position(st.cov, meas, independent)
                self.ctx.count("position_updates")
        st.position, st.heading, st.t = position, heading, msg.t
        integrity = self.params.integrity
        radius = gaussian_protection_radius(st.cov[:2, :2], integrity.containment)
        floor = None if self._floors is None else int(self._floors.floor_of_z(position[2]))
        self.ctx.publish("pose", PoseEstimate(
            t=msg.t, agent=msg.agent, device=msg.device, position=position.copy(),
            heading=heading, cov=st.cov[:4, :4].copy(), floor=floor,
            protection_radius=radius, trusted=trusted(radius, integrity, contradicted)))
        self.ctx.publish("odometry", Odometry(
            t=msg.t, agent=msg.agent, device=msg.device, t_start=msg.t - dt, delta=move,
            dheading=msg.dheading + dangle, cov=q, position=position.copy(),
            heading=heading, motion=msg.motion,
            yaw_drift_rate_sigma=msg.yaw_drift_rate_sigma))

    def _step_noise(self, st: _AgentState, msg: Odometry, delta: np.ndarray) -> np.ndarray:
        """The step's odometry covariance (4, 4) in the building frame, with the floors for
        what INS covariances tend to leave out (heading noise, step length)."""
        g = planar_rotation(st.transform.angle, 4)
        q = g @ np.asarray(msg.cov, float) @ g.T
        length2 = float(delta[:2] @ delta[:2])
        least = self.params.step_noise
        q[3, 3] = max(q[3, 3], least.heading_sigma ** 2) + \
            (self.params.drift.turn_sigma * msg.dheading) ** 2
        for i in (0, 1):
            q[i, i] = max(q[i, i], least.length_sigma ** 2 * length2)
        return q

    def _contradicts(self, cov_xy: np.ndarray, off: np.ndarray) -> bool:
        """Whether a correction ``off`` (2,) [m] from the odometry's prediction is beyond
        the contradiction gate of the covariance ``cov_xy`` (2, 2) [m^2]."""
        x, y = float(off[0]), float(off[1])
        if math.hypot(x, y) < 1e-6:
            return False               # rounding, not a correction
        a, b, d = float(cov_xy[0, 0]), float(cov_xy[0, 1]), float(cov_xy[1, 1])
        det = a * d - b * b
        if not det > 0.0:
            return True                # singular: no room for any correction
        m2 = (d * x * x - 2.0 * b * x * y + a * y * y) / det
        return not m2 <= self.params.drift.contradiction_gate

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


def _building(ctx):
    try:
        return ctx.building
    except NoBuilding as exc:
        raise ValueError("a start at the building entrance needs a building: add "
                         "'building:' to the pipeline, use a source that brings one, or "
                         "give the start pose (start: {mode: pose, position: [x, y, z], "
                         "heading: ...})") from exc


def _propagate(cov: np.ndarray, move: np.ndarray, dt: float, q: np.ndarray) -> np.ndarray:
    """Covariance (6, 6) after a step ``move`` (3,) [m] over ``dt`` [s] with the step's
    own noise ``q`` (4, 4): a heading error turns the step, the heading rate adds to the
    heading, a scale error lengthens the step."""
    f = np.eye(6)
    f[0, 3], f[1, 3] = -move[1], move[0]
    f[3, 4] = dt
    f[0, 5], f[1, 5] = move[0], move[1]
    out = f @ cov @ f.T
    out[:4, :4] += q
    return out
