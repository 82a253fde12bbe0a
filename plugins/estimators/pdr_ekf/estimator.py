"""The ``pdr_ekf`` estimator: foot-INS strides + RFID tags on doors -> 1 Hz building poses.

The pipeline of the RFID/MEMS paper (rfid-mems-ekf):

* **Odometry** (one increment per stride of the instrumented foot, from ``zupt_ins`` in
  its own frame, or from ``dead_reckoning`` already in the building frame, possibly
  ORCA-corrected) is classified into the paper's gait classes (:mod:`.gait`), its height
  change taken from the building's stair flights it walks (:mod:`.flight_tracker`; without
  a building map: the paper's counted stairs), and accumulated.
* Every ``update_period`` (1 s, "System model": synchronous mode) the accumulated strides
  drive the process model (eq. 2) of the EKF (:mod:`.filter`, state eq. 1), then the tag
  events that arrived are applied, and a pose is published.
* **Deployment** (``TagDeployment``): the new tag is associated with the most probable
  free tag site of the building by the distance cost of the tag database
  (:class:`~firenav_framework.building.tags.TagDatabase`, "RFID and Database"), and the
  deploying agent's position is corrected to it. When no site is probable enough the tag
  is tentative and the correction to it is weakened by the other candidates (:mod:`.association`).
  The database is one per estimator: the tags of the first team serve every later agent
  of the run.
* **Detection** (``TagDetection``): the tag's site is a 3-D position update. A read of a
  tentative tag weighs its candidates again; a read that contradicts the track (beyond
  ``rfid.gate``) is re-associated to a free site the track is at, else it re-locates the
  track with a widened covariance (or is refused); either way the pose is not trusted
  until a tag agrees with the track again.
* After a deployment or a detection at a door (or stair end), the next strides give the
  door-crossing heading update of eq. 3 (:mod:`.door_heading`).

Ports: ``pose`` (PoseEstimate at the time of the last stride integrated, covariance from
P over E, N, Z and the heading perturbation, ``floor`` from Z, ``protection_radius`` from
P's horizontal block, ``trusted`` from it and the contradiction flag) and ``diagnostics``
(tag associations, re-associations, contradictions, rejected tags and door updates,
unknown tags).
"""
from __future__ import annotations

import heapq
import itertools
import math
from dataclasses import dataclass, field

import numpy as np

from firenav_framework import (Estimator, Odometry, PerAgent, PoseEstimate, TagDeployment,
                               TagDetection)
from firenav_framework.building.tags import TagDatabase, TagSite
from firenav_framework.geometry import rot2, wrap_angle
from firenav_framework.integrity import gaussian_protection_radius, trusted
from firenav_framework.messages import Message, PressureHeight, Tick

from ..odometry_input import accept_odometry
from ..start_pose import entrance_of, entrance_start
from .association import Candidates, site_weights, spread_about_best
from .baro_floor import BaroFloor
from .door_heading import HeadingWindow, door_heading_measurement
from .filter import I_DTHETA, I_LAMBDA, I_Z, PdrFilter
from .flight_tracker import FlightTracker
from .gait import STAIR_GAITS, GaitClassifier, GaitConfig, StrideGait, count_stairs
from .height import Flight, StairFlights, snap_levels
from .history import StrideHistory
from .params import PdrEkfParams

__all__ = ["PdrEkfEstimator"]

#: Odometry motion labels -> gait classes (``gait.source: odometry``).
MOTION_GAITS = {"walk": "FW", "crawl": "FW", "stairs_up": "SC", "stairs_down": "SDF",
                "stairs_down_backward": "SDB", "still": "still"}
#: Height uncertainty after a snap to a floor level or landing: 1 sigma [m].
SNAP_SIGMA = 0.05
#: Floor of the odometry's horizontal covariance per stride, so that P never collapses [m^2].
MIN_STRIDE_VAR = 1e-6


@dataclass
class _Agent:
    """Everything kept for one firefighter."""

    device: str = ""
    filt: PdrFilter | None = None
    psi0: float = 0.0                 # odometry frame -> building frame rotation [rad]
    gait: GaitClassifier | None = None
    history: StrideHistory = field(default_factory=StrideHistory)
    t_odo: float = -math.inf          # end of the last stride [s]
    t_cycle: float | None = None      # time of the last synchronous update [s]
    t_published: float = -math.inf
    walk_dir: float = 0.0             # last walking direction, building frame before dtheta
    # accumulated since the last update (eq. 2 input)
    acc_d: np.ndarray = field(default_factory=lambda: np.zeros(2))
    acc_cov: np.ndarray = field(default_factory=lambda: np.zeros((2, 2)))
    acc_dz: float = 0.0
    acc_var_z: float = 0.0
    acc_turn: float = 0.0
    flights: FlightTracker | None = None   # the building's flights (stair_zone set)
    # free counting (no flights): the paper's stairs, retracted and snapped
    stair_run: int = 0                # stair strides since the last level one
    last_dz: float = 0.0              # height counted for the previous stride [m]
    snap: bool = False                # a flight just ended: try the floor-level snap
    events: list = field(default_factory=list)       # heap of (t, seq, message)
    window: HeadingWindow | None = None
    window_ready: bool = False
    last_tag: tuple[str, float] | None = None
    contradicted: bool = False        # a tag read contradicted the track, none agreed since
    baro: BaroFloor | None = None
    stairs_t: float = -math.inf       # end of the last stride classed as stairs [s]


class PdrEkfEstimator(Estimator):
    """RFID/MEMS extended Kalman filter: [E, N, Z, step scale, heading perturbation], tags on doors."""

    name = "pdr_ekf"
    inputs = (Odometry, TagDetection, TagDeployment, PressureHeight)
    outputs = {"pose": PoseEstimate}
    needs_building = True
    Params = PdrEkfParams

    @classmethod
    def tick_period(cls, params: PdrEkfParams) -> float | None:
        return params.update_period

    def __init__(self, params: PdrEkfParams, ctx):
        super().__init__(params, ctx)
        self.state: PerAgent[_Agent] = PerAgent(lambda agent: _Agent())
        self._seq = itertools.count()
        self.tags: TagDatabase | None = None
        self._stairs: StairFlights | None = None
        self._levels = np.zeros(0)
        self._door = params.door_heading.config()
        self._tentative: dict[str, Candidates] = {}     # tag id -> candidate sites
        self._site_pos = np.zeros((0, 3))
        self._floor_levels = np.zeros(0)

    def start(self) -> None:
        building = self.ctx.building
        self.tags = TagDatabase(building)
        for tag_id, site_id in self.params.rfid.surveyed.items():
            try:
                self.tags.assign(tag_id, site_id)
            except KeyError as exc:
                sites = ", ".join(s.id for s in self.tags.sites[:8])
                raise ValueError(f"rfid.surveyed: {exc.args[0]} (sites look like: {sites}, ...)") from None
        self._site_pos = np.array([self._site_z(s) for s in self.tags.sites]).reshape(-1, 3)
        self._stairs = StairFlights(building, self.params.height.stair_zone or 1.0)
        self._levels = snap_levels(building)
        self._floor_levels = np.array([f.z for f in building.floors])
        if self.params.start.mode == "entrance":
            entrance_of(building, self.params.start.entrance)   # fail now, clearly, if none

    def reset(self, agent: str) -> None:
        """Forget ``agent``: its state, what its reads said of tentative tags, and the
        tentative tags it deployed (its resolved tags stay on their doors for the
        others)."""
        self.state.reset(agent)
        for tag_id, cands in list(self._tentative.items()):
            cands.forget(agent)
            if cands.deployer == agent:
                del self._tentative[tag_id]
                self.tags.forget(tag_id)

    # -- input ---------------------------------------------------------------------------
    def handle(self, stream: str, msg: Message) -> None:
        if isinstance(msg, Tick):
            for agent, st in self.state.items():
                self._cycle(agent, st, msg.t)
        elif isinstance(msg, Odometry):
            self._odometry(msg)
        elif isinstance(msg, PressureHeight):
            self._pressure_height(msg)
        elif isinstance(msg, (TagDetection, TagDeployment)):
            if not self.params.rfid.enabled:
                return
            if not msg.agent or not math.isfinite(msg.t):
                self.ctx.count("bad_tag_events")
                return
            st = self.state[msg.agent]
            heapq.heappush(st.events, (msg.t, next(self._seq), msg))
        else:
            self.ctx.count("ignored_messages")

    def finish(self) -> None:
        for agent, st in self.state.items():
            self._cycle(agent, st, max(st.t_odo, st.t_cycle or -math.inf), final=True)
            if st.events:
                self.ctx.count("tag_events_unused", len(st.events))

    # -- odometry ----------------------------------------------------------------------
    def _odometry(self, msg: Odometry) -> None:
        st = self.state[msg.agent]
        if not self._accept(st, msg):
            return
        if st.filt is None:
            if self.params.start.mode != "unknown" and _is_still(msg):
                # standing at the start: the INS yaw may drift, so the start heading
                # belongs to the moment the walk begins
                self.ctx.count("strides_before_start")
                return
            self._initialise(msg.agent, st, msg)
        self._integrate(st, msg)
        if self.params.update_period is None:
            self._cycle(msg.agent, st, msg.t)

    def _accept(self, st: _Agent, msg: Odometry) -> bool:
        """Whether a stride is usable: well-formed, new, from the agent's tracked device."""
        if not accept_odometry(self.ctx, msg, st.t_odo):
            return False
        if not st.device:
            st.device = msg.device
        elif msg.device != st.device:
            self.ctx.count("odometry_other_device")
            self.ctx.warn_once(msg.t, "second_odometry_device",
                               f"odometry of {msg.device} ignored: {msg.agent} is tracked with "
                               f"{st.device}", agent=msg.agent)
            return False
        return True

    def _integrate(self, st: _Agent, msg: Odometry) -> None:
        """Classify a stride, rotate it into the building frame, find its height change,
        and add it to the eq. 2 input of the next update, the history and the heading
        window."""
        delta = np.asarray(msg.delta, float)
        now = self._now(st)
        gait = self._classify(st, msg, delta, msg.heading - 0.5 * msg.dheading, now)
        R = rot2(st.psi0)
        d = R @ delta[:2]
        cov = R @ np.asarray(msg.cov, float)[:2, :2] @ R.T
        if gait.gait != "still":
            cov = cov + np.eye(2) * max(self.params.process.stride_noise ** 2, MIN_STRIDE_VAR)
            st.walk_dir = math.atan2(d[1], d[0])
        if gait.gait in STAIR_GAITS:
            st.stairs_t = msg.t
        if st.flights is not None:
            label, dz, var_z, level = self._flight_height(msg.agent, st, gait, d, now, msg.t)
        else:
            label, dz, var_z, level = gait.gait, *self._counted_height(st, gait, msg, now), None
        st.acc_d += d
        st.acc_cov += cov
        st.acc_dz += dz
        st.acc_var_z += var_z
        st.acc_turn += abs(msg.dheading)
        if level is not None:
            # the height is a level of the building now: Z + the pending height = level
            st.filt.set_height(level - st.acc_dz, SNAP_SIGMA ** 2)
            st.acc_var_z = 0.0
        start = msg.t_start if not math.isfinite(st.t_odo) else max(msg.t_start, st.t_odo)
        st.history.add(start, msg.t, d, dz, cov, label)
        st.t_odo = msg.t
        self.ctx.count(f"strides_{label}")
        if st.flights is None and label in STAIR_GAITS:
            st.stair_run += 1
        elif st.flights is None and label == "FW":
            st.snap = st.snap or st.stair_run > 0
            st.stair_run = 0
        if st.window is not None and label != "still":
            st.window_ready = st.window.add(d, self._door) or st.window_ready

    def _now(self, st: _Agent) -> np.ndarray:
        """Estimated position (3,) [m] after the strides accumulated since the last update."""
        x = st.filt.x
        xy = x[:2] + x[I_LAMBDA] * (rot2(x[I_DTHETA]) @ st.acc_d)
        return np.array([xy[0], xy[1], x[I_Z] + st.acc_dz])

    def _classify(self, st: _Agent, msg: Odometry, delta: np.ndarray, foot: float,
                  now: np.ndarray) -> StrideGait:
        near = (self.params.height.stair_zone is None or not len(self._stairs)
                or (st.flights is not None and st.flights.on_stairs)
                or self._stairs.near(now) is not None)
        stride = st.gait.classify(delta, foot, near)
        if self.params.gait.source == "odometry" and msg.motion in MOTION_GAITS:
            return StrideGait(MOTION_GAITS[msg.motion], float(delta[2]), stride.d)
        return stride

    def _flight_height(self, agent: str, st: _Agent, gait: StrideGait, d: np.ndarray,
                       now: np.ndarray, t: float) -> tuple[str, float, float, float | None]:
        """Gait class, height change [m], its variance [m^2] and the level [m] the height
        is set to (or None) of one stride ending at ``t`` [s] that starts at ``now``
        (:meth:`_now`), from the building's flights (:mod:`.flight_tracker`)."""
        x = st.filt.x
        d_b = x[I_LAMBDA] * (rot2(x[I_DTHETA]) @ d)
        step = st.flights.stride(gait.gait, gait.dz, d_b, now[:2] + d_b, float(now[2]), t)
        label = "FW" if step.vetoed else gait.gait
        if step.vetoed:
            self.ctx.count("stair_strides_off_flights")
        if step.ended:
            self.ctx.count(f"flights_{step.ended}")
            verb = "completed" if step.ended == "complete" else "left"
            self.ctx.diagnose(t, "info", f"flight_{step.ended}",
                              f"{agent} {verb} flight {_flight_name(step.flight)}: height "
                              f"{step.z:.2f} m, floor {self._floor(step.z)}", agent=agent)
        var = (step.stairs * self.params.height.stair_sigma) ** 2
        return label, step.z - float(now[2]), var, step.z if step.settled else None

    def _counted_height(self, st: _Agent, gait: StrideGait, msg: Odometry,
                        now: np.ndarray) -> tuple[float, float]:
        """Height change [m] and its variance [m^2] of one stride without the building's
        flights: the INS's, or the paper's counted stairs (retracted when the next stride
        does not confirm them)."""
        p = self.params
        if p.height.source == "ins":
            return gait.dz, float(msg.cov[2, 2])
        dz = var = 0.0
        if gait.gait in STAIR_GAITS:
            rise = (self._stairs.step_rise_at(now) if p.height.step_height_from_building
                    else None) or p.height.step_height
            n = count_stairs(gait.dz, rise, p.height.max_stairs_per_stride)
            dz, var = n * rise, (n * p.height.stair_sigma) ** 2
        counted = dz
        if gait.retract:
            dz -= st.last_dz
            self.ctx.count("stair_strides_retracted")
        st.last_dz = counted
        return dz, var

    def _pressure_height(self, msg: PressureHeight) -> None:
        """A barometer height: the height follows it, offset removed, except on a flight
        of the stair map (:mod:`.baro_floor`)."""
        p = self.params.barometer
        st = self.state[msg.agent]
        if not p.enabled or st.filt is None:
            return
        if not (math.isfinite(msg.t) and math.isfinite(msg.height)):
            self.ctx.count("bad_pressure_heights")
            self.ctx.report(msg.t if math.isfinite(msg.t) else 0.0, "bad_pressure_height",
                            "barometer heights that are not numbers, skipped",
                            agent=msg.agent, key=msg.agent)
            return
        if st.baro is None:
            st.baro = BaroFloor(p.config())
        z, var = st.baro.update(msg.t, float(msg.height), self._floor_levels,
                                learn=msg.t - st.stairs_t > p.window)
        self.ctx.count("pressure_heights")
        if st.flights is not None and st.flights.on_stairs:
            return
        now = self._now(st)
        if self._floor(z) != self._floor(now[2]):
            self.ctx.count("baro_floor_corrections")
            self.ctx.report(msg.t, "baro_floor", "barometer floor corrections (the stairs "
                            f"said otherwise), last at ({now[0]:.1f}, {now[1]:.1f}): height "
                            f"{now[2]:.2f} m -> {z:.2f} m, floor {self._floor(z)}",
                            agent=msg.agent, key=msg.agent, level="info")
        st.filt.set_height(z - st.acc_dz, var)

    # -- start -------------------------------------------------------------------------
    def _initialise(self, agent: str, st: _Agent, first: Odometry) -> None:
        """Place the odometry frame in the building (start pose, psi0) and start the filter."""
        p = self.params
        foot0 = first.heading - first.dheading
        window = None
        if p.start.mode == "unknown":
            start = np.asarray(first.position, float) - np.asarray(first.delta, float)
            st.psi0 = 0.0
        elif p.start.mode == "pose":
            position, heading = p.start.pose_of(agent)
            start = np.asarray(position, float)
            st.psi0 = wrap_angle(heading - foot0)
        else:
            start, ent = entrance_start(self.ctx.building, p.start.entrance)
            st.psi0 = wrap_angle(ent.heading - foot0)
            if p.door_heading.at_entrance:
                window = HeadingWindow(f"entrance {ent.id}", ent.heading, False, first.t_start)
        x0 = np.array([start[0], start[1], start[2], 1.0, 0.0, 0.0])
        P0 = np.diag([p.start.sigma_position ** 2, p.start.sigma_position ** 2, 0.05 ** 2,
                      p.process.scale_sigma ** 2, p.start.sigma_heading ** 2,
                      p.process.heading_rate_sigma ** 2])
        st.filt = PdrFilter(x0, P0)
        st.gait = GaitClassifier(p.gait_config())
        if p.height.stair_zone is not None and p.height.source == "stairs" and len(self._stairs):
            st.flights = FlightTracker(self._stairs, p.height.flight_config())
        st.walk_dir = wrap_angle(foot0 + st.psi0)
        st.t_cycle = first.t_start
        if p.door_heading.enabled:
            st.window = window

    # -- the synchronous update -----------------------------------------------------------
    def _cycle(self, agent: str, st: _Agent, t: float, final: bool = False) -> None:
        """Eq. 2 prediction with the strides since the last update, then the tag events and
        door heading, then the pose."""
        if st.filt is None or st.t_cycle is None:
            return
        p = self.params
        dt = max(0.0, t - st.t_cycle)
        st.filt.predict(st.acc_d, st.acc_dz, st.acc_cov, st.acc_var_z,
                        var_lambda=p.process.scale_rw ** 2 * dt,
                        var_dtheta=p.process.heading_rw ** 2 * dt + (p.process.heading_turn_noise * st.acc_turn) ** 2,
                        dt=dt, var_omega=p.process.heading_rate_rw ** 2 * dt)
        st.acc_d, st.acc_cov = np.zeros(2), np.zeros((2, 2))
        st.acc_dz = st.acc_var_z = st.acc_turn = 0.0
        st.t_cycle = max(st.t_cycle, t)
        while st.events and (st.events[0][0] <= st.t_odo or t - st.events[0][0] >= p.rfid.max_wait
                             or final):
            _, _, msg = heapq.heappop(st.events)
            if isinstance(msg, TagDeployment):
                self._deployment(agent, st, msg)
            else:
                self._detection(agent, st, msg)
        if st.window is not None and st.window_ready:
            self._door_heading(agent, st)
        if st.snap:
            self._floor_snap(st)
        self._publish(agent, st)

    def _position_at(self, st: _Agent, t: float) -> tuple[np.ndarray, np.ndarray, tuple]:
        """Estimated position (3,) [m] at time ``t`` and its horizontal covariance (2, 2),
        with the displacement since then (for the delayed update)."""
        D, dz, C = st.history.since(t)
        x = st.filt.x
        R = rot2(x[I_DTHETA])
        lam = x[I_LAMBDA]
        pos = x[:3] - np.array([*(lam * (R @ D)), dz])
        cov = st.filt.P[:2, :2] + lam ** 2 * (R @ C @ R.T)
        return pos, cov, (D, dz, C)

    def _deployment(self, agent: str, st: _Agent, msg: TagDeployment) -> None:
        """Associate a new tag with the most probable door (distance cost), then correct;
        a tag no door is probable enough for is tentative (:mod:`.association`)."""
        p = self.params
        pos, cov, since = self._position_at(st, msg.t)
        floor = self._floor(pos[2])
        known = self.tags.lookup(msg.tag_id)
        why = "no tag site close enough"
        cands = None
        sigma = cov + np.eye(2) * p.rfid.sigma ** 2
        try:
            site = self.tags.associate(msg.tag_id, pos, floor, sigma=sigma,
                                       gate=p.rfid.associate_gate)
        except LookupError as exc:
            site, why = None, str(exc)
        if site is None:
            self.ctx.count("tags_not_associated")
            self.ctx.diagnose(msg.t, "warning", "tag_not_associated",
                              f"tag {msg.tag_id} deployed by {agent} near ({pos[0]:.1f}, "
                              f"{pos[1]:.1f}) on floor {floor}: {why}", agent=agent)
            return
        if known is None:
            self.ctx.count("tags_associated")
            costs = self.tags.costs(pos, floor, sigma)
            free = self.tags.free
            free[self._site_index(site)] = True
            cands = site_weights(costs, free, agent)
            dist = float(np.hypot(*(site.position[:2] - pos[:2])))
            best = cands.best()[1] if cands is not None else 1.0
            if best < p.rfid.associate_confidence:
                self._tentative[msg.tag_id] = cands
                self.ctx.count("tags_tentative")
                self.ctx.diagnose(msg.t, "info", "tag_ambiguous",
                                  f"tag {msg.tag_id} deployed by {agent} near ({pos[0]:.1f}, "
                                  f"{pos[1]:.1f}) on floor {floor}: {self._describe(cands)}; "
                                  f"tentatively {site.id}", agent=agent)
            else:
                cands = None
                self.ctx.diagnose(msg.t, "info", "tag_associated",
                                  f"tag {msg.tag_id} -> {site.id} (floor {site.floor}), "
                                  f"{dist:.1f} m from {agent}'s estimate ({100 * best:.0f} %)",
                                  agent=agent)
        if p.rfid.correct_on_deploy:
            self._position_update(agent, st, msg.t, msg.tag_id, site, since, gate=None,
                                  candidates=cands)
        self._open_window(st, site, msg.t)
        st.last_tag = (msg.tag_id, msg.t)

    def _site_index(self, site: TagSite) -> int:
        return next(i for i, s in enumerate(self.tags.sites) if s.id == site.id)

    def _site_z(self, site: TagSite) -> np.ndarray:
        """The position update's measurement of a site: E, N and its floor level [m]."""
        return np.array([site.position[0], site.position[1],
                         self.ctx.building.floors[site.floor].z])

    def _describe(self, cands: Candidates) -> str:
        order = np.argsort(-cands.weights)[:3]
        return ", ".join(f"{self.tags.sites[cands.sites[k]].id} {100 * cands.weights[k]:.0f} %"
                         for k in order)

    def _reweigh(self, agent: str, t: float, tag_id: str, pos: np.ndarray,
                 cov: np.ndarray) -> tuple[TagSite, Candidates | None]:
        """A read of a tentative tag by ``agent`` at ``t``: its candidates weighed with the
        reader's estimate ``pos`` (3,), ``cov`` (2, 2); the tag is re-associated when
        another site becomes the probable one. The tag's site and the candidates left
        (None: resolved)."""
        p = self.params
        site = self.tags.lookup(tag_id)
        costs = self.tags.costs(pos, None, cov + np.eye(2) * p.rfid.sigma ** 2)
        open_ = self.tags.free
        open_[self._site_index(site)] = True          # other tags' sites are not candidates
        cands = self._tentative[tag_id]
        cands.add(agent, np.where(open_, costs, np.inf))
        i, w = cands.best()
        if self.tags.sites[i].id != site.id:
            self._reassociate(agent, t, tag_id, site, self.tags.sites[i], pos, w)
            site = self.tags.sites[i]
        if w >= p.rfid.associate_confidence:
            del self._tentative[tag_id]
            self.ctx.count("tags_resolved")
            return site, None
        return site, cands

    def _reassociate(self, agent: str, t: float, tag_id: str, old: TagSite, new: TagSite,
                     pos: np.ndarray, weight: float) -> None:
        self.tags.assign(tag_id, new.id)
        self.ctx.count("tags_reassociated")
        self.ctx.diagnose(t, "warning", "tag_reassociated",
                          f"tag {tag_id} read by {agent} at ({pos[0]:.1f}, {pos[1]:.1f}) "
                          f"floor {self._floor(pos[2])}: moved from {old.id} ({old.position[0]:.1f}, "
                          f"{old.position[1]:.1f}) to {new.id} ({new.position[0]:.1f}, "
                          f"{new.position[1]:.1f}), {100 * weight:.0f} %", agent=agent)

    def _detection(self, agent: str, st: _Agent, msg: TagDetection) -> None:
        p = self.params
        if st.last_tag is not None and st.last_tag[0] == msg.tag_id \
                and msg.t - st.last_tag[1] < p.rfid.repeat_holdoff:
            self.ctx.count("tag_repeats_ignored")
            return
        site = self.tags.lookup(msg.tag_id)
        if site is None:
            self.ctx.count("tags_unknown")
            self.ctx.warn_once(msg.t, "unknown_tag", f"{agent} read tag {msg.tag_id}, which no "
                               "one deployed and no survey lists: not used", agent=agent,
                               key=msg.tag_id)
            return
        if not st.history.covers(msg.t) and math.isfinite(st.t_odo) and msg.t < st.t_odo:
            self.ctx.count("tag_events_too_old")
            return
        pos, cov, since = self._position_at(st, msg.t)
        cands = None
        if msg.tag_id in self._tentative:
            site, cands = self._reweigh(agent, msg.t, msg.tag_id, pos, cov)
        elif p.rfid.gate is not None and self._beyond_gate(site, pos, cov):
            site = self._contradiction(agent, msg.t, msg.tag_id, site, pos, cov)
        if self._position_update(agent, st, msg.t, msg.tag_id, site, since, gate=p.rfid.gate,
                                 candidates=cands):
            self._open_window(st, site, msg.t)
            st.last_tag = (msg.tag_id, msg.t)

    def _beyond_gate(self, site: TagSite, pos: np.ndarray, cov: np.ndarray) -> bool:
        """Whether ``site`` is beyond ``rfid.gate`` from the estimate ``pos``, ``cov``."""
        p = self.params
        d = self._site_z(site)[:2] - pos[:2]
        S = cov + np.eye(2) * p.rfid.sigma ** 2
        return float(d @ np.linalg.solve(S, d)) > p.rfid.gate ** 2

    def _contradiction(self, agent: str, t: float, tag_id: str, site: TagSite,
                       pos: np.ndarray, cov: np.ndarray) -> TagSite:
        """A read of a known tag far beyond the gate from ``agent``'s estimate: either the
        track drifted or the tag sits elsewhere than the database says. When the track
        is trusted (its protection radius within the alert limit) and a free site is
        the probable place of the read, the tag is re-associated there; otherwise the
        tag's site stands (and the update re-locates or refuses)."""
        p = self.params
        radius = gaussian_protection_radius(cov, p.integrity.containment)
        if radius <= p.integrity.alert_limit and tag_id not in p.rfid.surveyed:
            sigma = cov + np.eye(2) * p.rfid.sigma ** 2
            costs = self.tags.costs(pos, self._floor(pos[2]), sigma)
            cands = site_weights(costs, self.tags.free)
            if cands is not None:
                i, w = cands.best()
                if costs[i] <= p.rfid.gate ** 2 and w >= p.rfid.associate_confidence:
                    new = self.tags.sites[i]
                    self._reassociate(agent, t, tag_id, site, new, pos, w)
                    return new
        return site

    def _position_update(self, agent: str, st: _Agent, t: float, tag_id: str, site: TagSite,
                         since: tuple, gate: float | None,
                         candidates: Candidates | None = None) -> bool:
        """Eq. "RFID Positioning": the site's E, N and its floor level for Z; for a
        tentative tag the candidates' spread about its site added to R."""
        p = self.params
        z = self._site_z(site)
        Rm = np.diag([p.rfid.sigma ** 2, p.rfid.sigma ** 2, p.rfid.sigma_z ** 2])
        if candidates is not None:
            _, spread = spread_about_best(self._site_pos[candidates.sites],
                                          candidates.weights)
            Rm[:2, :2] += spread
        D, dz, C = since
        self._tag_level(agent, st, t, site, z[2], dz)
        relocate = p.rfid.relocate_heading_sigma if p.rfid.on_gate == "relocate" else None
        res = st.filt.update_position(z, Rm, D, dz, C, gate=gate, relocate=relocate)
        off = (f"tag {tag_id} at {site.id} ({z[0]:.1f}, {z[1]:.1f}) floor {site.floor} is "
               f"{np.hypot(*res.innovation[:2]):.1f} m from {agent}'s estimate "
               f"({math.sqrt(res.nis):.1f} sigma)")
        if res.relocated:
            st.contradicted = True
            if p.rfid.relocate_scale:
                st.filt.reset_scale(1.0, p.process.scale_sigma ** 2)
            self.ctx.count("tag_relocations")
            self.ctx.diagnose(t, "warning", "tag_relocation",
                              f"{off}: the track had drifted; re-located at the tag, not "
                              "trusted until a tag agrees", agent=agent)
        if res.applied:
            self.ctx.count("tag_updates")
            if not res.relocated and candidates is None:
                st.contradicted = False
            if site.kind == "stair" and st.flights is not None:
                self._stair_end(agent, st, t, site, float(z[2]))
            return True
        st.contradicted = True
        self.ctx.count("tag_updates_rejected")
        self.ctx.diagnose(t, "warning", "tag_rejected",
                          f"{off}: not used (a duplicated tag id, or a wrong association?); "
                          "not trusted until a tag agrees", agent=agent)
        return False

    def _stair_end(self, agent: str, st: _Agent, t: float, site: TagSite, level: float) -> None:
        """A tag at a stair's bottom or top (read at ``t``): the flight tracker knows the
        agent was at that end, and the strides since may have gone down (or up) it."""
        step = st.flights.at_stair_end(site.ref, level, t)
        if step is None:
            return
        st.filt.set_height(step.z, SNAP_SIGMA ** 2)
        self.ctx.count("stair_end_replays")
        self.ctx.diagnose(t, "info", "stair_end_replay",
                          f"{agent} read the tag at {site.id}: the strides since went "
                          f"on the stair, height {step.z:.2f} m",
                          agent=agent)

    def _tag_level(self, agent: str, st: _Agent, t: float, site: TagSite, level: float,
                   dz_since: float) -> None:
        """A tag read far from the estimated height: the height goes to the tag's level.

        The height is a level of the building plus counted stairs, known to centimetres
        when the flights were walked as the filter thinks, off by a whole flight when one
        was missed; a Gaussian update with the tag's height noise would move it by a
        fraction of a flight per read. A tag is on a door jamb or at a stair end of a
        known floor, and its reader was within a metre or two of it."""
        gate = self.params.rfid.level_gate
        z_then = float(st.filt.x[I_Z]) - dz_since
        if gate is None or abs(level - z_then) <= gate:
            return
        st.filt.set_height(level + dz_since, SNAP_SIGMA ** 2)
        if st.flights is not None:
            st.flights.abandon()
        self.ctx.count("tag_level_relocations")
        self.ctx.diagnose(t, "warning", "tag_level_relocation",
                          f"tag at {site.id} (floor {site.floor}) read {z_then - level:+.2f} m "
                          f"from {agent}'s estimated height: height set to its level",
                          agent=agent)

    def _open_window(self, st: _Agent, site: TagSite, t: float) -> None:
        """Collect the strides after the tag for the door heading (eq. 3)."""
        door = self.params.door_heading
        if not door.enabled or site.kind not in door.sites:
            return
        if st.window is not None:
            self.ctx.count("door_headings_superseded")
        st.window = HeadingWindow(site.id, site.heading, True, t)
        st.window_ready = False
        for s in st.history.after(t):
            if s.gait != "still":
                st.window_ready = st.window.add(s.d, self._door) or st.window_ready

    def _door_heading(self, agent: str, st: _Agent) -> None:
        win, st.window, st.window_ready = st.window, None, False
        m = door_heading_measurement(win, float(st.filt.x[I_DTHETA]), self._door)
        text = (f"{win.site}: crossing {math.degrees(m.crossing):.0f} deg, MEMS walking "
                f"{math.degrees(m.mean_mems):.0f} deg, discrepancy "
                f"{math.degrees(m.discrepancy):+.1f} deg")
        if not m.accepted:
            self.ctx.count("door_headings_rejected")
            self.ctx.diagnose(win.t, "info", "door_heading_rejected", text + ": not used",
                              agent=agent)
            return
        st.filt.update_heading(m.z, m.var)
        self.ctx.count("door_headings")
        self.ctx.diagnose(win.t, "info", "door_heading", text + f", sigma "
                          f"{math.degrees(math.sqrt(m.var)):.1f} deg", agent=agent)

    def _floor_snap(self, st: _Agent) -> None:
        """A flight just ended: a height near a floor level or landing is set to it
        (not with a barometer: it knows the level better)."""
        st.snap = False
        if self.params.height.floor_snap <= 0 or not len(self._levels) or st.baro is not None:
            return                # a barometer decides the level (_pressure_height)
        z = float(st.filt.x[I_Z])
        level = float(self._levels[np.argmin(np.abs(self._levels - z))])
        if abs(level - z) <= self.params.height.floor_snap:
            st.filt.set_height(level, SNAP_SIGMA ** 2)
            self.ctx.count("floor_snaps")

    # -- output ---------------------------------------------------------------------------
    def _publish(self, agent: str, st: _Agent) -> None:
        if not st.t_odo > st.t_published:
            return
        x, P = st.filt.x, st.filt.P
        idx = [0, 1, 2, I_DTHETA]
        cov = P[np.ix_(idx, idx)].copy()
        radius = gaussian_protection_radius(cov[:2, :2], self.params.integrity.containment)
        self.ctx.publish("pose", PoseEstimate(
            t=st.t_odo, agent=agent, device=st.device, position=x[:3].copy(),
            heading=wrap_angle(st.walk_dir + x[I_DTHETA]), cov=cov,
            floor=self._floor(x[I_Z]), protection_radius=radius,
            trusted=trusted(radius, self.params.integrity, st.contradicted)))
        st.t_published = st.t_odo

    def _floor(self, z: float) -> int:
        """Floor of height ``z`` [m], to the millimetre: a counted landing half way between
        two floors falls on the building's tie-break side, not on a rounding error's."""
        return int(self.ctx.building.floor_of_z(round(float(z), 3)))


def _flight_name(f: Flight) -> str:
    return f"{f.stair}/{f.index}"


def _is_still(msg: Odometry) -> bool:
    """A rest event or a stride too short to walk (the gait classifier's 'still')."""
    return msg.motion == "still" or float(np.linalg.norm(msg.delta)) < GaitConfig.still_distance
