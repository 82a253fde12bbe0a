"""The ``particle_filter`` estimator: map-aided INS odometry (search-pattern paper §IV-E).

Per firefighter, once per odometry update (the paper downsamples odometry to 2 Hz,
§V-B; faster odometry is summed into increments of at least ``update_interval_s``):

1. time update: move every particle by the increment rotated by its own frame
   rotation, add noise (:mod:`.motion`; none over 'still' increments with
   ``noise_while_still: false``), turn each frame rotation by its drift rate
   (``yaw_rate_sigma_dps`` > 0, for an INS with an uncalibrated yaw gyro bias), change
   floors on stairs (:mod:`.stairs`);
2. measurement updates: every attached constraint adds log-weights
   (:mod:`.constraint`), e.g. ``wall_crossing`` and ``search_pattern_icp`` (eq. 3);
3. particles removed by a constraint or with a weight below epsilon = weight_floor/N
   are replaced by copies of the others (§IV-E); constraints may then replace the
   lowest-weight particles (pseudo-observation resampling);
4. resampling (systematic by default) when the effective sample size drops below
   ``resample_below_ess`` * N (1 = every update, 0 = never);
5. output: the weighted mean pose (the MMSE estimate of §V-B) with its covariance,
   and the map-error monitor of §V-E (:mod:`.map_error`).

Uncertainty signal: the published pose's covariance; ``cov[0,0] + cov[1,1]`` is the
paper's "variance summed over both horizontal directions" (§V-E). While it exceeds
``map_error_variance_m2`` the pose has ``trusted=False``; a rise above it after the
filter had converged raises the ``map_error`` warning diagnostic, cleared
(``active=False``) when the filter converges again.
"""
from __future__ import annotations

import math
import zlib
from collections import deque
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from firenav_framework import (Estimator, GroundTruth, Odometry, Params, PerAgent,
                               PoseEstimate, param)
from firenav_framework.capabilities.odometry_history import OdometryHistory
from firenav_framework.capabilities.particles import ParticleConstraint, ParticleStep, Particles
from firenav_framework.geometry import wrap_angles

from .initialisation import around_pose, near_point, uniform_free_space
from .map_error import SpreadMonitor
from .motion import MotionNoise, propagate
from .particles import ParticleSummary, local_log_weight, normalise_log_weights
from .resampling import Resampler, replace_removed, resample_indices
from .stairs import apply_stairs

__all__ = ["ParticleFilter"]


class ParticleFilterParams(Params):
    particles: int = param(500, gt=0, description="particles per firefighter (N_p, §V-B)")
    init: Literal["unknown", "known", "entrance", "truth"] = param(
        "unknown", description="initial state: unknown (spread over the free space, all "
        "headings), known (`start`), entrance (near a building entrance), truth (the "
        "agent's first ground-truth pose: evaluation of the known-start case only)")
    start: tuple[float, float, float] | None = param(
        None, description="init=known: start pose [x m, y m, walking heading deg]")
    start_floor: int = param(0, ge=0, description="init=known: start floor index")
    start_sigma_m: float = param(0.1, unit="m", ge=0, description="init=known/truth: position spread")
    start_heading_sigma_deg: float = param(5.0, unit="deg", ge=0,
                                           description="init=known/truth: heading spread")
    entrance: str | None = param(None, description="init=entrance: entrance id (default: the first)")
    entrance_radius_m: float = param(1.5, unit="m", gt=0,
                                     description="init=entrance: particles within this radius")
    entrance_heading_sigma_deg: float = param(30.0, unit="deg", ge=0,
                                              description="init=entrance: heading spread about "
                                              "the entrance's inward heading")
    position_noise_m: float = param(0.12, unit="m", ge=0,
                                    description="time-update position noise per axis per "
                                    "noise_period_s (§V-B)")
    noise_period_s: float = param(0.5, unit="s", gt=0,
                                  description="update period the noise figures refer to (2 Hz in §V-B)")
    heading_noise_deg_per_m: float = param(2.0, unit="deg/m", ge=0,
                                           description="time-update heading noise per metre walked (§V-B)")
    noise_while_still: bool = param(True, description="add the time-update noise also over "
                                    "odometry increments labelled 'still' (the paper adds it "
                                    "at every 2 Hz update); false: a foot at rest, where a "
                                    "ZUPT INS does not drift, does not spread the particles")
    step_scale_sigma: float = param(0.0, ge=0, lt=0.5,
                                    description="spread of a per-particle step-length scale "
                                    "around 1 (0 disables the scale state)")
    yaw_rate_sigma_dps: float = param(0.0, unit="deg/s", ge=0,
                                      description="spread of a per-particle drift rate of the "
                                      "INS heading, for odometry whose yaw gyro bias was not "
                                      "calibrated (e.g. an IMU's turn-on bias; 0 disables)")
    weight_floor: float = param(0.01, ge=0, lt=1,
                                description="particles with weight below weight_floor/N are "
                                "replaced (epsilon = 0.01/N_p, §V-B)")
    resampling: Resampler = param("systematic", description="resampling scheme")
    resample_below_ess: float = param(0.5, ge=0, le=1,
                                      description="resample when ESS < this * N (1 = every "
                                      "update, 0 = never)")
    update_interval_s: float = param(0.5, unit="s", ge=0,
                                     description="odometry is summed to at least this interval "
                                     "per update (2 Hz in §V-B)")
    offset_window_m: float = param(20.0, unit="m", gt=0,
                                   description="path length over which the IMU-yaw to walking-"
                                   "direction offset is estimated (footnote 4)")
    map_error_variance_m2: float = param(3.0, unit="m^2", gt=0,
                                         description="var_x + var_y above which the estimate "
                                         "is not trusted / a map error is suspected (§V-E)")
    map_error_clear_m2: float | None = param(None, unit="m^2", gt=0,
                                             description="var_x + var_y below which a map error "
                                             "clears (default: the same threshold)")
    injected_weight: Literal["neighbours", "uniform"] = param(
        "neighbours", description="weight of particles a constraint injects: the kernel-"
        "weighted mean weight of the particles already near them (neighbours), or 1/N each "
        "(uniform)")
    injected_kernel_m: float = param(1.0, unit="m", gt=0,
                                     description="injected_weight=neighbours: kernel width per axis")
    injected_kernel_deg: float = param(30.0, unit="deg", gt=0,
                                       description="injected_weight=neighbours: kernel width on heading")
    seed: int = param(0, description="random seed (combined with the agent name)")


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


@dataclass
class _AgentState:
    rng: np.random.Generator
    history: OdometryHistory
    monitor: SpreadMonitor
    particles: Particles | None = None
    pending: _Pending | None = None
    last_t: float = -math.inf
    walk_offset: float = 0.0
    #: recent ground truth while waiting to initialise from it (init: truth)
    truth: deque = field(default_factory=lambda: deque(maxlen=1024))
    #: var_x + var_y of the cloud after the last update [m^2]
    spread_m2: float = math.inf


class ParticleFilter(Estimator):
    """Map-aided particle filter on INS odometry with pluggable constraints (walls, search patterns)."""

    name = "particle_filter"
    inputs = (Odometry, GroundTruth)
    outputs = {"pose": PoseEstimate}
    accepts = (ParticleConstraint,)
    needs_building = True
    Params = ParticleFilterParams

    def __init__(self, params: ParticleFilterParams, ctx):
        super().__init__(params, ctx)
        if params.init == "known" and params.start is None:
            raise ValueError("init: known needs start: [x, y, heading_deg]")
        self.noise = MotionNoise(position_sigma_m=params.position_noise_m,
                                 period_s=params.noise_period_s,
                                 heading_sigma_rad_per_m=math.radians(params.heading_noise_deg_per_m))
        self.state: PerAgent[_AgentState] = PerAgent(self._new_agent)

    # ------------------------------------------------------------------ lifecycle
    def _new_agent(self, agent: str) -> _AgentState:
        p = self.params
        seed = np.random.SeedSequence([p.seed, zlib.crc32(agent.encode())])
        keep = max([p.offset_window_m] + [getattr(c, "history_m", 0.0) for c in self.constraints])
        clear = p.map_error_clear_m2 if p.map_error_clear_m2 is not None else p.map_error_variance_m2
        return _AgentState(rng=np.random.default_rng(seed), history=OdometryHistory(2 * keep + 10),
                           monitor=SpreadMonitor(p.map_error_variance_m2, clear))

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
            if self.params.init == "truth" and self.state[msg.agent].particles is None:
                self.state[msg.agent].truth.append(msg)
            return
        if isinstance(msg, Odometry):
            self._odometry(msg)

    def _odometry(self, msg: Odometry) -> None:
        st = self.state[msg.agent]
        delta = np.asarray(msg.delta, dtype=float)
        pos = np.asarray(msg.position, dtype=float)
        if delta.shape != (3,) or pos.shape != (3,) or not (
                np.all(np.isfinite(delta)) and np.all(np.isfinite(pos))
                and math.isfinite(msg.heading) and math.isfinite(msg.dheading)):
            self.ctx.count("bad_odometry_skipped")
            return
        if msg.t <= st.last_t:
            self.ctx.count("odometry_out_of_order_skipped")
            return
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
        if msg.motion == "still" and not self.params.noise_while_still:
            st.pending.quiet_s += msg.t - msg.t_start
        if msg.t - st.pending.t_start >= self.params.update_interval_s:
            self._update(msg.agent, st)

    # ------------------------------------------------------------------ initialisation
    def _initialise(self, msg: Odometry, st: _AgentState) -> bool:
        """Create the particles at the pose *before* the first increment."""
        p = self.params
        building = self.ctx.building
        n = p.particles
        rng = st.rng
        if p.init == "unknown":
            xy, heading, floor = uniform_free_space(n, building, rng)
        elif p.init == "known":
            x, y, hdg = p.start
            xy, heading, floor = around_pose(n, np.array([x, y]), math.radians(hdg), p.start_floor,
                                             p.start_sigma_m, math.radians(p.start_heading_sigma_deg), rng)
        elif p.init == "truth":
            if not st.truth:
                self.ctx.count("waiting_for_truth_to_initialise")
                return False
            # the true pose at the start of the first increment
            tr = min(st.truth, key=lambda g: abs(g.t - msg.t_start))
            st.truth.clear()
            xy, heading, floor = around_pose(
                n, tr.position, tr.heading if math.isfinite(tr.heading) else None,
                tr.floor if tr.floor is not None else int(building.floor_of_z(tr.position[2])),
                p.start_sigma_m, math.radians(p.start_heading_sigma_deg), rng)
        else:
            entrances = building.entrances
            if p.entrance is not None:
                entrances = [e for e in entrances if e.id == p.entrance]
            if not entrances:
                raise ValueError(f"init: entrance, but building {building.name!r} has no "
                                 f"entrance{' ' + repr(p.entrance) if p.entrance else ''}")
            e = entrances[0]
            xy, heading, floor = near_point(n, building.floors[e.floor], e.position,
                                            p.entrance_radius_m, e.heading,
                                            math.radians(p.entrance_heading_sigma_deg), rng)
        ins_heading0 = msg.heading - msg.dheading
        scale = 1.0 + p.step_scale_sigma * rng.standard_normal(n) if p.step_scale_sigma else 1.0
        rate = (math.radians(p.yaw_rate_sigma_dps) * rng.standard_normal(n)
                if p.yaw_rate_sigma_dps else 0.0)
        st.particles = Particles.create(xy, wrap_angles(heading - ins_heading0), floor, scale, rate)
        st.history.append(msg.t_start, np.asarray(msg.position, float) - msg.delta, ins_heading0)
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
        propagate(p, pend.delta[:2], noisy_s, self.noise, rng, drift_s=msg.t - pend.t_start)
        apply_stairs(p, float(pend.delta[2]), self.ctx.building)
        odo = msg if pend.t_start == msg.t_start else Odometry(
            t=msg.t, agent=agent, device=msg.device, t_start=pend.t_start, delta=pend.delta,
            dheading=pend.dheading, cov=msg.cov, position=msg.position, heading=msg.heading,
            motion=msg.motion)
        step = ParticleStep(agent=agent, t=msg.t, odometry=odo, before=before, particles=p,
                            history=st.history, ins_heading=msg.heading,
                            walk_offset=st.walk_offset, rng=rng, building=self.ctx.building,
                            spread_m2=st.spread_m2)
        self._measurement_updates(step, before)
        self._replace_by_constraints(step)
        if len(p) and p.effective_sample_size() < self.params.resample_below_ess * len(p):
            idx = resample_indices(p.weights, len(p), rng, self.params.resampling)
            st.particles = p = p.take(idx)
            p.logw[:] = -math.log(len(p))
            self.ctx.count("resampled")
        self._publish(agent, st, step)

    def _update_offset(self, st: _AgentState) -> None:
        """Footnote 4: re-estimate the IMU-yaw to walking-direction offset."""
        est = st.history.walk_offset(self.params.offset_window_m)
        if est is None:
            return
        st.walk_offset = est

    def _measurement_updates(self, step: ParticleStep, before: Particles) -> None:
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
            return
        logw = p.logw + total
        if not normalise_log_weights(logw):
            # every particle refuted: keep the prior weights rather than lose the cloud
            self.ctx.count("all_particles_refuted")
            self.ctx.diagnose(step.t, "info", "all_particles_refuted",
                              "every particle was ruled out by the constraints; update skipped",
                              agent=step.agent)
            return
        p.logw = logw
        eps = self.params.weight_floor / len(p)
        removed = ~np.isfinite(logw) | (logw < math.log(eps) if eps > 0 else False)
        self.ctx.count("replaced_particles", replace_removed(p, removed, step.rng))

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
            if self.params.injected_weight == "uniform":
                new.logw = np.full(k, -math.log(len(p)))
            else:
                new.logw = local_log_weight(p, new.xy, new.yaw, new.floor,
                                            self.params.injected_kernel_m,
                                            math.radians(self.params.injected_kernel_deg))
                new.logw[~np.isfinite(new.logw)] = math.log(self.params.weight_floor / len(p)) - 1.0
            p.put(worst, new)
            normalise_log_weights(p.logw)
            self.ctx.count("injected_particles", k)

    # ------------------------------------------------------------------ output
    def _publish(self, agent: str, st: _AgentState, step: ParticleStep) -> None:
        p = st.particles
        building = self.ctx.building
        levels = np.array([f.z for f in building.floors])
        summary = ParticleSummary.of(p, step.walking_heading(p), levels[p.floor] + p.climb)
        st.spread_m2 = summary.spread_m2
        event = st.monitor.update(summary.spread_m2)
        if event == "map_error":
            self.ctx.diagnose(step.t, "warning", "map_error",
                              f"position variance {summary.spread_m2:.1f} m^2 exceeds "
                              f"{st.monitor.threshold_m2:g} m^2: estimate not trustworthy, "
                              "possible map error", agent=agent)
        elif event == "recovered":
            self.ctx.diagnose(step.t, "info", "map_error",
                              f"position variance back to {summary.spread_m2:.1f} m^2: "
                              "estimate converged again", agent=agent, active=False)
        self.ctx.publish("pose", PoseEstimate(
            t=step.t, agent=agent, device=step.odometry.device,
            position=np.array([summary.xy[0], summary.xy[1], summary.z]),
            heading=summary.heading, cov=summary.cov, floor=summary.floor,
            trusted=st.monitor.trusted(summary.spread_m2)))
