"""Team fusion: per firefighter, one pose from every single-method estimator that runs.

``team_fusion`` takes the building-frame pose streams of the other estimators (INS
alone, the particle filter, ORCA map matching, the RFID EKF, breadcrumb GEN: whatever
the crew's kit lets run; each is optional), the building-frame odometry of the
firefighter (``dead_reckoning``'s ``odometry``) and, where fitted, the barometer height;
and publishes one :class:`PoseEstimate` per odometry step (a step twice when corrected, 0.):

0. **Wait.** A step is fused once every input that answered a recent step has sent its
   pose of this one (the methods run on the same odometry and answer after it), at the
   latest when the next step arrives; an input's pose of a step already published (it
   skipped the one before) makes that step published again, corrected.
1. **Carry.** Each input's last pose is carried to the step's time along the odometry
   (the odometry's steps turned into that input's heading where the input knows its
   heading), its covariance grown with the distance carried and the age; inputs older
   than ``propagation.max_age`` are left out.
2. **Learn** each input's covariance factor online from its disagreement with the
   other inputs (:mod:`.quality`), applied before the gate: an input that contradicts
   the others widens until it agrees, the tightest one is not out-voted.
3. **Gate.** Two inputs contradict each other when their difference lies beyond the
   chi-square gate with both covariances, or they name floors more than one apart
   (one apart is the stairs, where the methods switch floor at different moments). The largest
   set of mutually consistent inputs is fused; an input outside it is left out,
   counted (``rejected_inputs``, ``rejected:<stream>``) and reported with the place.
4. **Fuse.** Covariance intersection of the set (:mod:`.fusion`): the inputs share the
   foot-INS odometry, so their errors are correlated by an unknown amount. Height and
   heading take the same weights.
5. **Rival sets.** When the inputs split into rival sets of the same size that
   contradict each other (two inputs that disagree, nothing to arbitrate), the pose is
   their mixture, its protection radius holds every set's 99 % disc, and it is not
   trusted (``inputs_disagree`` diagnostic with the place).
6. **Floor** by vote of the fused inputs' floors (their stairs evidence), one each, of
   the inputs that only vote (``inputs.<stream>.position: false``), and the barometer's
   floor; a tie keeps the floor before.
7. **Integrity.** ``protection_radius`` from the fused covariance
   (:func:`~firenav_framework.integrity.gaussian_protection_radius`) or the mixture;
   ``trusted`` from :func:`~firenav_framework.integrity.trusted`, and only while at
   least ``support.inputs`` fused inputs each bound the pose within ``support.radius``
   on their own: an input that is wrong with a tight covariance can only be caught by
   another tight input.

Team effects live inside the methods and are used through their poses, not repeated
here: the RFID EKF's tag database is shared by every reader, the breadcrumb graph's
nodes by every crew (docs/team-fusion.md).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from firenav_framework import Estimator, Message, Odometry, PerAgent, PoseEstimate
from firenav_framework.geometry import wrap_angle
from firenav_framework.integrity import gaussian_protection_radius, trusted
from firenav_framework.messages import PressureHeight

from ..odometry_input import accept_odometry
from .fusion import (Hypothesis, chi2_2dof_quantile, consistent_hypotheses, leave_one_out,
                     mixture)
from .params import InputSettings, TeamFusionParams
from .quality import InputQuality
from .trail import OdometryTrail

__all__ = ["TeamFusionEstimator"]

_MIN_VAR = 1e-6     # [m^2], [rad^2]: least variance taken from an input


@dataclass
class _Carried:
    """One input's pose carried to the fusion time."""

    stream: str
    mean: np.ndarray          # (2,) [m]
    cov: np.ndarray           # (2, 2) [m^2]
    z: float
    var_z: float
    heading: float
    var_heading: float
    floor: int | None


@dataclass
class _Agent:
    trail: OdometryTrail
    quality: InputQuality
    odometry_stream: str = ""
    last_odometry_t: float | None = None
    inputs: dict[str, PoseEstimate] = field(default_factory=dict)
    baro: PressureHeight | None = None
    floor: int | None = None
    published_t: float = -math.inf
    pending: tuple[float, str] | None = None     # the step (time, device) not yet fused
    waiting: set[str] = field(default_factory=set)   # inputs whose pose of it is due


class TeamFusionEstimator(Estimator):
    """Per firefighter: the poses of every method fused (gate, covariance intersection, floor vote)."""

    name = "team_fusion"
    inputs = (PoseEstimate, Odometry, PressureHeight)
    outputs = {"pose": PoseEstimate}
    Params = TeamFusionParams

    def __init__(self, params: TeamFusionParams, ctx):
        super().__init__(params, ctx)
        keep = params.propagation.max_age + 5.0
        q = params.quality
        self.state: PerAgent[_Agent] = PerAgent(lambda agent: _Agent(
            OdometryTrail(keep), InputQuality(q.time_constant, q.max_factor, q.margin)))
        self._threshold = chi2_2dof_quantile(params.gate.probability)
        self._default_input = InputSettings()

    def reset(self, agent: str) -> None:
        self.state.reset(agent)

    # ---- input ---------------------------------------------------------------------
    def handle(self, stream: str, msg: Message) -> None:
        if isinstance(msg, Odometry):
            self._odometry(stream, msg)
        elif isinstance(msg, PoseEstimate):
            self._pose(stream, msg)
        elif isinstance(msg, PressureHeight):
            if math.isfinite(msg.height) and math.isfinite(msg.sigma):
                self.state[msg.agent].baro = msg
            else:
                self.ctx.count("bad_heights")
        else:
            self.ctx.count("ignored_messages")

    def _odometry(self, stream: str, msg: Odometry) -> None:
        st = self.state[msg.agent]
        if st.odometry_stream and stream != st.odometry_stream:
            self.ctx.count("ignored_odometry")
            self.ctx.warn_once(msg.t, "second_odometry", f"odometry of {msg.agent} on "
                               f"{stream} ignored: {st.odometry_stream} carries the inputs",
                               agent=msg.agent, key=stream)
            return
        if not accept_odometry(self.ctx, msg, st.last_odometry_t):
            return
        previous = st.last_odometry_t
        self._fuse_pending(msg.agent, st)
        st.odometry_stream = stream
        st.last_odometry_t = msg.t
        st.trail.add(msg.t, np.asarray(msg.position, float), float(msg.heading))
        # the step is fused once every input that kept up with the step before has sent
        # its pose of this one (the methods answer the same stride after the odometry),
        # at the latest at the next step
        st.pending = (msg.t, msg.device)
        recent = self.params.propagation.wait_for
        st.waiting = {s for s, p in st.inputs.items()
                      if previous is not None and previous - recent - 1e-9 <= p.t < msg.t - 1e-9}
        if not st.waiting:
            self._fuse_pending(msg.agent, st)

    def _fuse_pending(self, agent: str, st: _Agent) -> None:
        if st.pending is not None:
            t, device = st.pending
            st.pending = None
            st.waiting.clear()
            self._fuse(agent, st, t, device)

    def finish(self) -> None:
        for agent, st in self.state.items():
            self._fuse_pending(agent, st)

    def _pose(self, stream: str, msg: PoseEstimate) -> None:
        problem = _pose_problem(msg)
        if problem:
            self.ctx.count("bad_poses")
            self.ctx.report(msg.t, "bad_pose", f"poses skipped ({problem})", agent=msg.agent,
                            key=f"{msg.agent}/{stream}")
            return
        st = self.state[msg.agent]
        old = st.inputs.get(stream)
        if old is not None and msg.t < old.t:
            self.ctx.count("stale_poses")
            return
        st.inputs[stream] = msg
        if st.pending is not None and stream in st.waiting and msg.t >= st.pending[0] - 1e-9:
            st.waiting.discard(stream)
            if not st.waiting:
                self._fuse_pending(msg.agent, st)
        elif st.pending is None and abs(msg.t - st.published_t) < 1e-6:
            # an input's pose of the step already published (it skipped the step before):
            # the step again, corrected
            self._fuse(msg.agent, st, msg.t, msg.device, again=True)
        if not len(st.trail):
            # no odometry to carry the inputs (yet): fuse at each input pose instead
            self._fuse(msg.agent, st, msg.t, msg.device)

    # ---- fusion --------------------------------------------------------------------
    def _settings(self, stream: str) -> InputSettings:
        return self.params.inputs.get(stream, self._default_input)

    def _carry(self, st: _Agent, stream: str, pose: PoseEstimate, t: float) -> _Carried | None:
        prop = self.params.propagation
        age = t - pose.t
        if age > prop.max_age:
            return None
        age = max(age, 0.0)
        settings = self._settings(stream)
        cov = np.asarray(pose.cov, float) * settings.inflate
        xy = np.asarray(pose.position[:2], float).copy()
        z, heading = float(pose.position[2]), float(pose.heading)
        grow = prop.per_second ** 2 * age
        if len(st.trail) and pose.t < st.trail.last_t + 1e-9:
            shift, dheading, odo_heading = st.trail.motion(pose.t, t)
            if cov[3, 3] < prop.heading_sigma_max ** 2:
                c, s = math.cos(heading - odo_heading), math.sin(heading - odo_heading)
                shift[:2] = (c * shift[0] - s * shift[1], s * shift[0] + c * shift[1])
            xy += shift[:2]
            z += float(shift[2])
            heading = wrap_angle(heading + dheading)
            grow += (prop.per_metre * float(np.hypot(shift[0], shift[1]))) ** 2
        elif age > 0:
            grow += (prop.max_speed * age) ** 2
        return _Carried(stream, xy, cov[:2, :2] + np.eye(2) * grow, z,
                        max(float(cov[2, 2]) + grow, _MIN_VAR), heading,
                        max(float(cov[3, 3]), _MIN_VAR),
                        pose.floor if settings.floor else None)

    def _fuse(self, agent: str, st: _Agent, t: float, device: str, again: bool = False) -> None:
        if t < st.published_t or (t == st.published_t and not again):
            return
        carried: list[_Carried] = []        # fused
        floor_only: list[_Carried] = []     # only their floor votes
        for s, p in sorted(st.inputs.items()):
            c = self._carry(st, s, p, t)
            if c is not None:
                (carried if self._settings(s).position else floor_only).append(c)
        if not carried:
            self.ctx.count("steps_without_inputs")
            return
        means = np.array([c.mean for c in carried])
        raw = np.array([c.cov for c in carried])
        for k in range(len(raw)):
            raw[k] = 0.5 * (raw[k] + raw[k].T) + np.eye(2) * _MIN_VAR
        learn = self.params.quality.enabled
        covs = raw.copy()
        if learn:
            for k, c in enumerate(carried):
                covs[k] *= st.quality.factor(c.stream)
                c.cov = covs[k]
        hyps = consistent_hypotheses(means, covs, [c.floor for c in carried], self._threshold)
        containment = self.params.integrity.containment
        if len(hyps) == 1:
            mean, cov = hyps[0].mean, hyps[0].cov
            radius = gaussian_protection_radius(cov, containment)
            contradicted = False
        else:
            mean, cov, radius = mixture(hyps, containment)
            contradicted = True
            self.ctx.count("inputs_disagree")
            rivals = "; ".join("+".join(carried[i].stream for i in h.members) +
                               f" at ({h.mean[0]:.1f}, {h.mean[1]:.1f})" for h in hyps)
            self.ctx.report(t, "inputs_disagree", f"the inputs disagree with no majority "
                            f"({rivals}): not trusted, radius {radius:.1f} m",
                            agent=agent, key=agent)
        used = {i for h in hyps for i in h.members}
        support = sum(1 for i in used if gaussian_protection_radius(carried[i].cov, containment)
                      <= self.params.support.radius)
        unsupported = support < self.params.support.inputs
        for i, c in enumerate(carried):
            if i not in used:
                self.ctx.count("rejected_inputs")
                self.ctx.count(f"rejected:{c.stream}")
                off = float(np.hypot(*(c.mean - mean)))
                self.ctx.report(t, "input_rejected", f"{c.stream} contradicts the "
                                f"other inputs ({off:.1f} m from the fused ({mean[0]:.1f}, "
                                f"{mean[1]:.1f}), floor {c.floor}) and is left out",
                                agent=agent, key=f"{agent}/{c.stream}")
        if learn:
            self._learn(st, carried, hyps, means, raw, covs, mean, cov, t)
        weights = _member_weights(hyps, len(carried))
        z, var_z = _scalar_ci([c.z for c in carried], [c.var_z for c in carried], weights)
        heading, var_h = _heading_ci(carried, weights)
        floor = self._vote(st, [carried[i].floor for i in sorted(used)] +
                           [c.floor for c in floor_only], z, t)
        st.floor, st.published_t = floor, t
        cov4 = np.zeros((4, 4))
        cov4[:2, :2] = cov
        cov4[2, 2], cov4[3, 3] = var_z, var_h
        self.ctx.publish("pose", PoseEstimate(
            t=t, agent=agent, device=device, position=np.array([mean[0], mean[1], z]),
            heading=heading, cov=cov4, floor=floor, frame="building",
            protection_radius=radius,
            trusted=trusted(radius, self.params.integrity, contradicted or unsupported)))

    def _learn(self, st: _Agent, carried: list[_Carried], hyps: list[Hypothesis],
               means: np.ndarray, raw: np.ndarray, covs: np.ndarray, mean: np.ndarray,
               cov: np.ndarray, t: float) -> None:
        """Each input's disagreement with the team without it: for a fused input, the
        fusion of the others in its set (skipped when it is fused alone or they carry no
        weight); for one left out, the fused pose."""
        for k, c in enumerate(carried):
            home = next((h for h in hyps if k in h.members), None)
            if home is None:
                st.quality.update(c.stream, t, means[k], raw[k], mean, cov)
                continue
            if len(home.members) == 1:
                continue
            others = leave_one_out(home, means, covs, k)
            if others is not None:
                st.quality.update(c.stream, t, means[k], raw[k], *others)

    def _vote(self, st: _Agent, floors: list[int | None], z: float, t: float) -> int | None:
        """One vote per voting input that names a floor (``floors``: those of the
        consistent set(s) and of the floor-only inputs), the barometer's floor with its
        weight; a tie keeps the floor before. Votes are counted, not weighted by the
        fusion weights: inputs that share the INS height agree with each other whatever
        their covariances say."""
        votes: dict[int, float] = {}
        for f in floors:
            if f is not None:
                votes[f] = votes.get(f, 0.0) + 1.0
        baro = st.baro
        if baro is not None and t - baro.t <= self.params.floor.barometer_max_age \
                and self.ctx.has_building:
            f = int(self.ctx.building.floor_of_z(baro.height))
            votes[f] = votes.get(f, 0.0) + self.params.floor.barometer_weight
        if not votes:
            return int(self.ctx.building.floor_of_z(z)) if self.ctx.has_building else st.floor
        top = max(votes.values())
        leaders = [f for f, v in votes.items() if v >= top - 1e-12]
        if st.floor in leaders:
            return st.floor
        return min(leaders)


def _member_weights(hyps: list[Hypothesis], n: int) -> np.ndarray:
    """Each input's weight: its covariance-intersection weight, shared among rival sets."""
    w = np.zeros(n)
    for h in hyps:
        w[list(h.members)] += h.weights / len(hyps)
    return w


def _scalar_ci(values: list[float], variances: list[float],
               weights: np.ndarray) -> tuple[float, float]:
    """Covariance intersection of scalars with given weights: ``(value, variance)``."""
    v = np.asarray(variances, float)
    info = float(np.sum(weights / v))
    return float(np.sum(weights * np.asarray(values, float) / v)) / info, 1.0 / info


def _heading_ci(carried: list[_Carried], weights: np.ndarray) -> tuple[float, float]:
    """Heading [rad] as the information-weighted circular mean, its variance as for a scalar."""
    info = weights / np.array([c.var_heading for c in carried])
    s = float(np.sum(info * np.sin([c.heading for c in carried])))
    c = float(np.sum(info * np.cos([c.heading for c in carried])))
    return wrap_angle(math.atan2(s, c)), 1.0 / float(np.sum(info))


def _pose_problem(msg: PoseEstimate) -> str:
    """Why a pose cannot be fused, or ``""``."""
    if msg.frame != "building":
        return f"frame '{msg.frame}', not the building frame"
    pos = np.asarray(msg.position, float)
    cov = np.asarray(msg.cov, float)
    if not (np.all(np.isfinite(pos)) and math.isfinite(msg.heading)):
        return "position or heading not finite"
    if cov.shape != (4, 4) or not np.all(np.isfinite(cov)):
        return "covariance not finite"
    c = cov[:2, :2]
    if c[0, 0] <= 0 or c[1, 1] <= 0 or np.linalg.det(0.5 * (c + c.T)) <= 0 \
            or cov[2, 2] < 0 or cov[3, 3] < 0:
        return "horizontal covariance not positive definite"
    return ""
