"""The ``particle_filter`` estimator: map-aided INS odometry (search-pattern paper §IV-E).

Per firefighter, once per odometry update (the paper downsamples odometry to 2 Hz,
§V-B; faster odometry is summed into increments of at least ``update_interval``):

1. time update: move every particle by the increment rotated by its own frame
   rotation, add noise (:mod:`.motion`; none over 'still' increments with
   ``motion.noise_while_still: false``, the crawl noise over 'crawl' ones), turn each frame rotation by its drift rate
   (``motion.yaw_rate_sigma`` > 0, for an INS with an uncalibrated yaw gyro bias), change
   floors on stairs (:mod:`.stairs`);
2. measurement updates: every attached constraint adds log-weights
   (:mod:`.constraint`), e.g. ``wall_crossing`` and ``search_pattern_icp`` (eq. 3);
3. particles removed by a constraint or with a weight below epsilon =
   ``resampling.weight_floor``/N are replaced by copies of the others (§IV-E);
   constraints may then replace the lowest-weight particles (pseudo-observation
   resampling, weighted as ``injection`` says);
4. resampling (systematic by default) when the effective sample size drops below
   ``resampling.below_ess`` * N (1 = every update, 0 = never);
5. output: the weighted mean pose (the MMSE estimate of §V-B) with its covariance,
   and the map-error monitor of §V-E (:mod:`.map_error`).

Integrity (:mod:`.trust`): the published covariance is the cloud's (its horizontal
block ``trust.spread_scale`` squared times wider) plus a kernel of ``trust.kernel`` per
axis; ``protection_radius`` is the cloud's 99 % radius about the mean (a second cluster
counts in full; ``trust.spread_scale`` times wider); ``trusted`` holds while it is within
``integrity.alert_limit`` and no ``map_error`` is active. ``map_error`` (a warning with
the place, cleared with ``active=False``) comes from the spread monitor of §V-E
(:mod:`.map_error`: ``cov[0,0] + cov[1,1]`` above ``map_error.variance`` after the filter
had converged) or from the contradiction monitor (the constraints refuting most of the
cloud, during which the cloud is widened rather than held; with ``trust.plan_evidence``
also refuting parts of it over the last ``trust.plan_window`` metres). With ``trust.jump`` set, a
jump of the mean between hypotheses that the particles' own motion does not explain
(:class:`.trust.JumpMonitor`) raises ``hypothesis_jump`` and keeps the pose untrusted until
``trust.jump_evidence`` metres have been walked. With ``trust.refuted_evidence`` the pose
stays untrusted for that many metres after a contradiction of the plan, and with
``trust.untrusted_growth`` an untrusted pose's covariance and protection radius grow with
the distance walked since it was last trusted (:class:`.trust.DoubtMonitor`). With
``stairs.height_factor`` < 1 the particles' heights are checked against the INS's own
(:mod:`.height`): a particle on another floor than the INS's height says is down-weighted,
and a pose whose height disagrees is not trusted.
"""
from __future__ import annotations

import math
import zlib
from collections import deque
from dataclasses import dataclass, field
import numpy as np

from firenav_framework import Estimator, GroundTruth, Odometry, PerAgent, PoseEstimate
from firenav_framework.capabilities.odometry_history import OdometryHistory
from firenav_framework.capabilities.particles import ParticleConstraint, ParticleStep, Particles
from firenav_framework.geometry import wrap_angles
from firenav_framework.integrity import trusted

from .height import HeightCheck, particle_heights
from .initialisation import around_pose, near_point, uniform_free_space
from .map_error import SpreadMonitor
from ..odometry_input import accept_odometry
from ..start_pose import entrance_of
from .motion import propagate
from .params import ParticleFilterParams
from .particles import ParticleSummary, local_log_weight, normalise_log_weights
from .resampling import replace_removed, resample_indices
from .stairs import StairRegions
from .trust import (ContradictionMonitor, DoubtMonitor, JumpMonitor, PlanEvidenceMonitor,
                    cloud_protection_radius, retained_fraction, roughen)

__all__ = ["ParticleFilterEstimator"]


@dataclass
class _Pending:
    """Odometry summed since the last filter update."""

    t_start: float
    delta: np.ndarray
    dheading: float
    msg: Odometry
    #: seconds of the summed increments that add no time-update noise (still, with
    #: ``noise_while_still: false``)
    quiet_s: float = 0.0
    #: whether any of the summed increments is labelled 'crawl'
    crawl: bool = False


@dataclass
class _AgentState:
    rng: np.random.Generator
    history: OdometryHistory
    monitor: SpreadMonitor
    contradiction: ContradictionMonitor
    particles: Particles | None = None
    pending: _Pending | None = None
    last_t: float = -math.inf
    walk_offset: float = 0.0
    #: recent ground truth while waiting to initialise from it (start mode truth)
    truth: deque = field(default_factory=lambda: deque(maxlen=1024))
    #: var_x + var_y of the cloud after the last update [m^2]
    spread_m2: float = math.inf
    #: whether a map_error diagnostic is active (spread or contradiction)
    map_error: bool = False
    #: look-alike jump monitor (``trust.jump``; None: off)
    jump: JumpMonitor | None = None
    #: the plan's refutations summed over the last metres (``trust.plan_evidence``; None: off)
    evidence: PlanEvidenceMonitor | None = None
    #: whether the plan's refutations over the last metres contradict the motion
    plan_refuted: bool = False
    #: evidence after a contradiction and the untrusted pose's growth (None: both off)
    doubt: DoubtMonitor | None = None
    #: the particles' heights against the INS's (``stairs.height_factor``; None: off)
    height: HeightCheck | None = None


class ParticleFilterEstimator(Estimator):
    """Map-aided particle filter on INS odometry with pluggable constraints (walls, search patterns)."""

    name = "particle_filter"
    inputs = (Odometry, GroundTruth)
    outputs = {"pose": PoseEstimate}
    accepts = (ParticleConstraint,)
    needs_building = True
    Params = ParticleFilterParams

    def __init__(self, params: ParticleFilterParams, ctx):
        super().__init__(params, ctx)
        self.noise = params.motion.noise()
        self.crawl_noise = params.motion.noise(crawl=True)
        self.state: PerAgent[_AgentState] = PerAgent(self._new_agent)
        self._stairs: StairRegions | None = None
        self._floor_z: np.ndarray | None = None     # each floor's level [m], built once

    # ------------------------------------------------------------------ lifecycle
    def _new_agent(self, agent: str) -> _AgentState:
        p = self.params
        seed = np.random.SeedSequence([p.seed, zlib.crc32(agent.encode())])
        keep = max([p.offset_window] + [getattr(c, "history_m", 0.0) for c in self.constraints])
        clear = p.map_error.clear if p.map_error.clear is not None else p.map_error.variance
        tr = p.trust
        return _AgentState(rng=np.random.default_rng(seed), history=OdometryHistory(2 * keep + 10),
                           monitor=SpreadMonitor(p.map_error.variance, clear),
                           contradiction=ContradictionMonitor(tr.retained_floor, tr.smoothing,
                                                              tr.hold),
                           jump=(JumpMonitor(tr.jump, tr.jump_evidence, tr.jump_window)
                                 if tr.jump is not None else None),
                           evidence=(PlanEvidenceMonitor(tr.plan_evidence, tr.plan_window)
                                     if tr.plan_evidence is not None else None),
                           doubt=(DoubtMonitor(tr.refuted_evidence, tr.untrusted_growth)
                                  if tr.refuted_evidence > 0 or tr.untrusted_growth > 0
                                  else None),
                           height=(HeightCheck(p.stairs.height_tolerance, p.stairs.height_factor)
                                   if p.stairs.height_factor < 1
                                   and len(self.ctx.building.floors) > 1 else None))

    def reset(self, agent: str) -> None:
        self.state.reset(agent)
        for c in self.constraints:
            c.reset(agent)

    def finish(self) -> None:
        for agent, st in self.state.items():
            if st.pending is not None and st.particles is not None:
                self._update(agent, st)

    # ------------------------------------------------------------------ input
    def handle(self, stream: str, msg) -> None:
        if isinstance(msg, GroundTruth):
            if self.params.start.mode == "truth" and self.state[msg.agent].particles is None:
                self.state[msg.agent].truth.append(msg)
            return
        if isinstance(msg, Odometry):
            self._odometry(msg)

    def _odometry(self, msg: Odometry) -> None:
        st = self.state[msg.agent]
        if not accept_odometry(self.ctx, msg, st.last_t):
            return
        delta = np.asarray(msg.delta, dtype=float)
        st.last_t = msg.t
        if st.particles is None:
            if not self._initialise(msg, st):
                return
        if st.pending is None:
            st.pending = _Pending(msg.t_start, delta.copy(), msg.dheading, msg)
        else:
            st.pending.delta += delta
            st.pending.dheading += msg.dheading
            st.pending.msg = msg
        st.pending.crawl |= msg.motion == "crawl"
        if msg.motion == "still" and not self.params.motion.noise_while_still:
            st.pending.quiet_s += msg.t - msg.t_start
        if msg.t - st.pending.t_start >= self.params.update_interval:
            self._update(msg.agent, st)

    # ------------------------------------------------------------------ initialisation
    def _initialise(self, msg: Odometry, st: _AgentState) -> bool:
        """Create the particles at the pose *before* the first increment."""
        p, start = self.params, self.params.start
        building = self.ctx.building
        n = p.particles
        rng = st.rng
        if start.mode == "unknown":
            xy, heading, floor = uniform_free_space(n, building, rng)
        elif start.mode == "pose":
            position, hdg = start.pose_of(msg.agent)
            floor = start.floor if start.floor is not None else int(
                building.floor_of_z(position[2]))
            xy, heading, floor = around_pose(n, np.asarray(position[:2]), hdg, floor,
                                             start.sigma_position, start.sigma_heading, rng)
        elif start.mode == "truth":
            if not st.truth:
                self.ctx.count("waiting_for_truth_to_initialise")
                return False
            # the true pose at the start of the first increment
            tr = min(st.truth, key=lambda g: abs(g.t - msg.t_start))
            st.truth.clear()
            xy, heading, floor = around_pose(
                n, tr.position, tr.heading if math.isfinite(tr.heading) else None,
                tr.floor if tr.floor is not None else int(building.floor_of_z(tr.position[2])),
                start.sigma_position, start.sigma_heading, rng)
        else:
            e = entrance_of(building, start.entrance)
            xy, heading, floor = near_point(n, building.floors[e.floor], e.position,
                                            start.entrance_radius, e.heading,
                                            start.sigma_heading, rng)
        ins_heading0 = msg.heading - msg.dheading
        m = p.motion
        scale = 1.0 + m.step_scale_sigma * rng.standard_normal(n) if m.step_scale_sigma else 1.0
        rate = m.yaw_rate_sigma * rng.standard_normal(n) if m.yaw_rate_sigma else 0.0
        st.particles = Particles.create(xy, wrap_angles(heading - ins_heading0), floor, scale, rate)
        st.history.append(msg.t_start, np.asarray(msg.position, float) - msg.delta, ins_heading0)
        if st.height is not None and start.mode == "unknown":
            st.height = None     # no start floor to take the INS's height from
        elif st.height is not None:
            st.height.start(float(building.floors[int(floor[0])].z),
                            float(msg.position[2] - msg.delta[2]))
        return True

    # ------------------------------------------------------------------ one update
    def _update(self, agent: str, st: _AgentState) -> None:
        pend, st.pending = st.pending, None
        msg = pend.msg
        p, rng = st.particles, st.rng
        st.history.append(msg.t, np.asarray(msg.position, float), msg.heading)
        self._update_offset(st)
        before = p.copy()
        noisy_s = max(0.0, msg.t - pend.t_start - pend.quiet_s)
        noise = self.crawl_noise if pend.crawl else self.noise
        propagate(p, pend.delta[:2], noisy_s, noise, rng, drift_s=msg.t - pend.t_start)
        if self._stairs is None:
            self._stairs = StairRegions(self.ctx.building, self.params.stairs.margin)
        self._stairs.apply(p, float(pend.delta[2]))
        self._check_height(st, float(msg.position[2]))
        propagated_mean = p.weights @ p.xy if st.jump is not None else None
        odo = msg if pend.t_start == msg.t_start else Odometry(
            t=msg.t, agent=agent, device=msg.device, t_start=pend.t_start, delta=pend.delta,
            dheading=pend.dheading, cov=msg.cov, position=msg.position, heading=msg.heading,
            motion=msg.motion, yaw_drift_rate_sigma=msg.yaw_drift_rate_sigma)
        step = ParticleStep(agent=agent, t=msg.t, odometry=odo, before=before, particles=p,
                            history=st.history, ins_heading=msg.heading,
                            walk_offset=st.walk_offset, rng=rng, building=self.ctx.building,
                            spread_m2=st.spread_m2)
        walked_m = float(np.hypot(*pend.delta[:2]))
        retained = self._measurement_updates(step, before)
        self._contradiction(st, step, retained, walked_m)
        self._replace_by_constraints(step)
        resampling = self.params.resampling
        if len(p) and p.effective_sample_size() < resampling.below_ess * len(p):
            idx = resample_indices(p.weights, len(p), rng, resampling.scheme)
            st.particles = p = p.take(idx)
            p.logw[:] = -math.log(len(p))
            self.ctx.count("resampled")
        self._publish(agent, st, step, propagated_mean, walked_m)

    def _check_height(self, st: _AgentState, ins_z: float) -> None:
        """Down-weight the particles whose height is off the INS's (:mod:`.height`)."""
        if st.height is None:
            return
        p = st.particles
        ll = st.height.log_likelihood(particle_heights(p, self._levels()), ins_z)
        if np.any(ll):
            logw = p.logw + ll
            if normalise_log_weights(logw):
                p.logw = logw

    def _levels(self) -> np.ndarray:
        """(floors,) each floor's level [m]."""
        if self._floor_z is None:
            self._floor_z = np.array([f.z for f in self.ctx.building.floors])
        return self._floor_z

    def _update_offset(self, st: _AgentState) -> None:
        """Footnote 4: re-estimate the IMU-yaw to walking-direction offset."""
        est = st.history.walk_offset(self.params.offset_window)
        if est is None:
            return
        st.walk_offset = est

    def _measurement_updates(self, step: ParticleStep, before: Particles) -> float:
        """Apply every constraint's log-likelihoods; returns the retained share of the
        prior weight (:func:`.trust.retained_fraction`)."""
        p = step.particles
        total = np.zeros(len(p))
        for c in self.constraints:
            if not isinstance(c, ParticleConstraint):
                continue
            ll = c.log_likelihood(step)
            if ll is None:
                continue
            ll = np.asarray(ll, dtype=float)
            if ll.shape != (len(p),) or np.any(np.isnan(ll)) or np.any(ll == np.inf):
                raise ValueError(f"constraint '{c.ctx.id}' returned log-likelihoods of shape "
                                 f"{ll.shape} (need ({len(p)},), no NaN or +inf)")
            total += ll
        if not np.any(total):
            return 1.0
        retained = retained_fraction(p.logw, total)
        logw = p.logw + total
        if not normalise_log_weights(logw):
            # every particle refuted: keep the prior weights rather than lose the cloud
            self.ctx.count("all_particles_refuted")
            self.ctx.diagnose(step.t, "info", "all_particles_refuted",
                              "every particle was ruled out by the constraints; update skipped",
                              agent=step.agent)
            return 0.0
        p.logw = logw
        eps = self.params.resampling.weight_floor / len(p)
        removed = ~np.isfinite(logw) | (logw < math.log(eps) if eps > 0 else False)
        self.ctx.count("replaced_particles", replace_removed(p, removed, step.rng))
        return retained

    def _contradiction(self, st: _AgentState, step: ParticleStep, retained: float,
                       walked_m: float) -> None:
        """Follow how much of the cloud the plan refutes; widen the cloud while most of it
        is refuted at once."""
        tr = self.params.trust
        if st.evidence is not None:
            st.plan_refuted = st.evidence.update(retained, walked_m)
        mon = st.contradiction
        if tr.retained_floor > 0:
            if mon.update(step.t, retained):
                self.ctx.count("plan_contradictions")
            if mon.widening():
                roughen(step.particles, tr.widen_position, tr.widen_heading, step.rng)
        if st.doubt is not None:
            st.doubt.update(walked_m, st.plan_refuted or mon.widening())

    def _replace_by_constraints(self, step: ParticleStep) -> None:
        p = step.particles
        for c in self.constraints:
            if not isinstance(c, ParticleConstraint):
                continue
            new = c.replacements(step)
            if new is None or not len(new):
                continue
            k = min(len(new), len(p))
            worst = np.argpartition(p.logw, k - 1)[:k] if k < len(p) else np.arange(len(p))
            new = new.take(np.arange(k))
            inject = self.params.injection
            if inject.weight == "uniform":
                new.logw = np.full(k, -math.log(len(p)))
            else:
                new.logw = local_log_weight(p, new.xy, new.yaw, new.floor,
                                            inject.kernel_position, inject.kernel_heading)
                floor = self.params.resampling.weight_floor / len(p)
                new.logw[~np.isfinite(new.logw)] = math.log(floor) - 1.0
            p.put(worst, new)
            normalise_log_weights(p.logw)
            self.ctx.count("injected_particles", k)

    # ------------------------------------------------------------------ output
    def _publish(self, agent: str, st: _AgentState, step: ParticleStep,
                 propagated_mean: np.ndarray | None, walked_m: float) -> None:
        p = st.particles
        summary = ParticleSummary.of(p, step.walking_heading(p),
                                     particle_heights(p, self._levels()))
        st.spread_m2 = summary.spread_m2
        st.monitor.update(summary.spread_m2)
        self._map_error(agent, st, step.t, summary)
        self._jump(agent, st, step.t, summary.xy, propagated_mean, walked_m)
        tr, integ = self.params.trust, self.params.integrity
        widen = np.array([tr.spread_scale, tr.spread_scale, 1.0, 1.0])
        cov = summary.cov * np.outer(widen, widen)
        cov[0, 0] += tr.kernel ** 2
        cov[1, 1] += tr.kernel ** 2
        radius = cloud_protection_radius(p, summary.xy, summary.floor, integ.containment,
                                         tr.kernel, tr.spread_scale)
        ok = trusted(radius, integ, contradicted=st.map_error or (
            st.jump is not None and st.jump.awaiting_evidence) or (
            st.doubt is not None and st.doubt.awaiting_evidence) or (
            st.height is not None and st.height.disagrees(summary.z, float(step.odometry.position[2]))))
        if st.doubt is not None:
            grow = st.doubt.published(ok)
            cov[0, 0] += grow ** 2
            cov[1, 1] += grow ** 2
            radius = math.hypot(radius, grow * math.sqrt(-2.0 * math.log1p(-integ.containment)))
        self.ctx.publish("pose", PoseEstimate(
            t=step.t, agent=agent, device=step.odometry.device,
            position=np.array([summary.xy[0], summary.xy[1], summary.z]),
            heading=summary.heading, cov=cov, floor=summary.floor,
            protection_radius=radius, trusted=ok))

    def _jump(self, agent: str, st: _AgentState, t: float, mean: np.ndarray,
              propagated_mean: np.ndarray | None, walked_m: float) -> None:
        """Report a jump between hypotheses (:class:`.trust.JumpMonitor`) with both places."""
        if st.jump is None or propagated_mean is None:
            return
        if st.jump.update(t, mean - propagated_mean, walked_m):
            self.ctx.count("hypothesis_jumps")
            self.ctx.diagnose(
                t, "warning", "hypothesis_jump",
                f"the estimate jumped from near ({propagated_mean[0]:.1f}, "
                f"{propagated_mean[1]:.1f}) to ({mean[0]:.1f}, {mean[1]:.1f}) m without moving "
                f"there: not trusted until {st.jump.evidence_m:g} m more are walked",
                agent=agent)

    def _map_error(self, agent: str, st: _AgentState, t: float, summary: ParticleSummary) -> None:
        """One ``map_error`` episode per disturbance of the spread (§V-E) or contradiction of
        the plan: a warning with the place when it starts, cleared when both have ended."""
        spread = st.monitor.state == "disturbed"
        contra = st.contradiction.contradicted or st.plan_refuted
        now = spread or contra
        if now and not st.map_error:
            where = (f"near ({summary.xy[0]:.1f}, {summary.xy[1]:.1f}) m on floor "
                     f"{summary.floor}")
            how = ("the walls refute most of the cloud): widening"
                   if st.contradiction.contradicted else
                   f"the walls kept refuting the cloud over the last "
                   f"{self.params.trust.plan_window:g} m)")
            why = (f"the motion contradicts the plan {where} ({how}, estimate not "
                   "trustworthy" if contra else
                   f"position variance {summary.spread_m2:.1f} m^2 exceeds "
                   f"{st.monitor.threshold_m2:g} m^2 {where}: estimate not trustworthy, "
                   "possible map error")
            self.ctx.diagnose(t, "warning", "map_error", why, agent=agent)
        elif st.map_error and not now:
            self.ctx.diagnose(t, "info", "map_error",
                              f"estimate consistent with the plan again near "
                              f"({summary.xy[0]:.1f}, {summary.xy[1]:.1f}) m, variance "
                              f"{summary.spread_m2:.1f} m^2", agent=agent, active=False)
        st.map_error = now
