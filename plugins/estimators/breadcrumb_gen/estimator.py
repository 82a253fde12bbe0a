"""The ``breadcrumb_gen`` estimator: firefighters and breadcrumbs in one GEN (paper §IV-V).

Nodes of the extended relative measurement graph (§IV-E):

* the base station - an anchor at ``base.position`` (or the building's anchor ``base.id``);
* breadcrumbs - static; a drop adds the node with a relative-position edge to the
  dropping firefighter's state (its initial position comes from that firefighter's
  odometry, §V-A); a kicked breadcrumb (a ``moved`` drop from the sensor, §V-C) becomes
  a new node ``<id>#<n>`` tied to the old one by ``breadcrumbs.kick_sigma``;
* firefighter states ``<agent>@<k>`` - one per odometry step, each with a heading state
  ``<agent>@<k>/heading`` (below). The last ``graph.window`` states of each firefighter stay in
  the graph; older ones are marginalised (DeleteNode, eq. 17).

Edges: odometry steps, RSSI ranges (eqs. 18-21, with the antennas' heights as a constant
offset), encounters (the two nodes at the same place, linear), drops and kicks (linear).
Outliers (§IV-F): a step faster than ``odometry.max_speed`` is physically impossible and
replaced by the bare speed limit; a range or encounter beyond ``radio.weaken`` sigmas is
weakened (its variance scaled up to sit at ``radio.weaken`` sigmas), and one beyond
``radio.gate`` sigmas contradicts the graph: it is down-weighted further (the paper drops
it), counted, said with the place (``radio_contradiction``), and widens the firefighter's
published covariance until consistent links return. A range shorter than ``radio.near_range`` - or between nodes whose
estimated distance is below their relative uncertainty, where its direction is
meaningless - enters as a zero relative position with the range's spread ("the nodes
are within r of each other"), at least ``radio.near_sigma`` per axis (fast fading lets a
few short readings through from metres away, as it does for encounters). A range to a
fixed node from within ``radio.shadow_length`` walked of the last one used is not used:
its shadowing is the same (a firefighter waiting by a node gives one range).

Beyond the paper (``heading.enabled``; false gives the paper's GEN): a foot INS errs
mostly by a drifting heading (residual gyro bias, warm-up drift, gyro scale factor on
every turn), which independent step edges cannot express: a heading error bends whole
stretches of track, and the paper's position-only states would have to explain that
with many unlikely steps. So each state carries a heading correction
``h_k = (psi_k [rad], omega_k [rad/s], kappa_k [-])``: the true heading is the INS
heading plus ``psi``; ``psi`` drifts at ``omega`` (the residual gyro bias) and by
``kappa`` times every turn the INS measured (its scale-factor error). The motion model
``psi_k = psi_k-1 + omega dt + kappa dtheta + w`` is a linear edge (process noise: the
INS's own heading variance per step, and random walks of ``omega`` and ``kappa``); a
step is a relative position turned by ``psi_k`` (linearised and re-linearised like a
range). A loop closure at the base station or a breadcrumb then corrects the heading,
its drift rate and the breadcrumbs dropped on the drifting track, as one BLUE.

The odometry must be in the building frame (e.g. ``dead_reckoning`` output, which places
the INS track with the known start pose), or be rotated into it by ``odometry.rotation``
per agent: ranges and encounters fix positions relative to the base station but cannot
observe a rotation of the whole track about it, so the initial heading is an input
(the paper's firefighters start at the base station with a known heading).

Beyond the paper, the radio's path-loss model is learned online from links of known
length (``learn``, radio_model.py) and corrects the sensor's ranges and encounters.

Integrity: the published horizontal covariance is the graph's marginal (eq. 5) scaled by
the running normalised innovation of the firefighter's radio links when that says the
graph is optimistic (``consistency``), plus the size of an unresolved contradiction, plus
a doubt kept beside the graph that grows with the distance walked since a fixed node
(base station, breadcrumb) last confirmed the track (``consistency.doubt_per_m``): it does
not rest on the graph's odometry model being right; the protection radius is its 99 %
circle and ``trusted`` is derived from it (``integrity``).

Ports: ``pose`` - one :class:`PoseEstimate` per odometry step per firefighter (the
newest state, covariance as above); ``breadcrumbs`` - a :class:`PoseEstimate` per
breadcrumb touched by an update (``agent`` = the breadcrumb id, ``device`` = its graph
node), and all of them at the end; ``diagnostics``.
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field, replace

import numpy as np

from firenav_framework import BreadcrumbDrop, Estimator, Odometry, PoseEstimate, Range
from firenav_framework.contract import NoBuilding
from firenav_framework.geometry import planar_rotation, wrap_angle
from firenav_framework.integrity import gaussian_protection_radius, trusted

from ..odometry_input import accept_odometry
from .network import GeneralizedElectricalNetwork
from .params import BreadcrumbGenParams
from .radio_model import PathLossLearner

__all__ = ["BreadcrumbGenEstimator"]


@dataclass
class _State:
    key: str
    t: float
    speed: float          # horizontal speed of the step that ended here [m/s]
    heading: str | None   # its heading-state node (None without heading states)
    index: int = -1       # steps since the start (-1: the start state)
    path: float = 0.0     # horizontal distance the odometry walked since the start [m]


@dataclass
class _Agent:
    states: deque = field(default_factory=deque)        # recent _State, oldest first
    count: int = 0
    heading_var: float = 0.0        # summed INS heading variance (without heading states)
    pending: list = field(default_factory=list)          # radio/drop events waiting for a state
    last_range: dict = field(default_factory=dict)       # node -> t of the last range used
    mutual: dict = field(default_factory=dict)   # other firefighter -> deque of link times
    nearby: dict = field(default_factory=dict)   # fixed node -> path [m] at its last range
    nis: float = 1.0          # running normalised innovation of its radio links [-]
    widen: float = 0.0        # extra horizontal variance after a contradiction [m^2]
    doubt: float = 0.0        # doubt variance per horizontal axis (consistency.doubt_per_m) [m^2]
    contradicted: bool = False          # since the last contradiction, no consistent link
    last_said: float = -math.inf        # data time of the last contradiction diagnostic [s]
    unsaid: int = 0                     # contradictions since then


class BreadcrumbGenEstimator(Estimator):
    """Breadcrumb GEN/RMG: firefighters and breadcrumbs localised together (breadcrumb paper)."""

    name = "breadcrumb_gen"
    inputs = (Odometry, Range, BreadcrumbDrop)
    outputs = {"pose": PoseEstimate, "breadcrumbs": PoseEstimate}

    Params = BreadcrumbGenParams

    def __init__(self, params: BreadcrumbGenParams, ctx) -> None:
        super().__init__(params, ctx)
        p = self.params
        self.gen = GeneralizedElectricalNetwork(3, **p.graph.network_options())
        self._agents: dict[str, _Agent] = {}
        self._crumbs: dict[str, str] = {}             # breadcrumb id -> current graph node
        self._kicks: dict[str, int] = {}              # breadcrumb id -> relocations so far
        self._static: dict[tuple[str, str], list[float]] = {}   # fixed pair -> ranges
        self._touched: set[str] = set()
        self._base_ready = False
        lp = p.learn
        self._radio_model = PathLossLearner(lp.sigma_offset, lp.sigma_slope, lp.sigma_log,
                                            lp.min_samples) if lp.enabled else None
        self._dropped_by: dict[str, tuple[str, int]] = {}   # crumb node -> (agent, step)
        self._learnt_at: dict[tuple[str, str], float] = {}  # link -> t of its last sample
        self._doubt: dict[str, float] = {}   # fixed node -> its doubt variance per axis [m^2]

    # -- set-up ------------------------------------------------------------------------------
    def start(self) -> None:
        self._ensure_base()

    def _ensure_base(self) -> None:
        if self._base_ready:
            return
        p = self.params
        pos = p.base.position
        if pos is None:
            try:
                building = self.ctx.building
            except NoBuilding:
                raise ValueError("breadcrumb_gen needs base.position, or a building with an "
                                 f"anchor {p.base.id!r}") from None
            anchor = next((a for a in building.anchors if a.id == p.base.id), None)
            if anchor is None:
                raise ValueError(f"the building has no anchor {p.base.id!r}; set "
                                 "base.position")
            pos = anchor.position
        self.gen.add_anchor(p.base.id, np.asarray(pos, float))
        self._doubt[p.base.id] = 0.0
        self._base_ready = True

    def reset(self, agent: str) -> None:
        st = self._agents.pop(agent, None)
        if st is not None:
            for s in st.states:
                for node in (s.key, s.heading):
                    if node is not None and node in self.gen:
                        self.gen.delete_node(node)

    # -- input ---------------------------------------------------------------------------------
    def handle(self, stream: str, msg) -> None:
        if isinstance(msg, Odometry):
            self._odometry(msg)
        elif isinstance(msg, Range):
            self._radio(msg)
        elif isinstance(msg, BreadcrumbDrop):
            self._drop(msg)

    def _agent(self, agent: str) -> _Agent:
        st = self._agents.get(agent)
        if st is None:
            st = self._agents[agent] = _Agent()
        return st

    # -- odometry: a new firefighter state ---------------------------------------------------------
    def _odometry(self, msg: Odometry) -> None:
        p = self.params
        st = self._agent(msg.agent)     # a firefighter, even if this step is unusable
        if not accept_odometry(self.ctx, msg, st.states[-1].t if st.states else None):
            return
        rot = planar_rotation(p.odometry.rotation.get(msg.agent, 0.0))
        delta = rot @ np.asarray(msg.delta, float)
        cov = rot @ np.asarray(msg.cov, float)[:3, :3] @ rot.T
        dt = max(msg.t - msg.t_start, 1e-3)
        step = float(np.hypot(delta[0], delta[1]))
        with self.gen.batch():
            if not st.states:
                self._first_state(msg, st, rot)
            prev = st.states[-1]
            key = f"{msg.agent}@{st.count}"
            st.count += 1
            heading = self._heading_state(msg, key, prev) if p.heading.enabled else None
            self.gen.add_node(key)
            if step / dt > p.odometry.max_speed:                 # §IV-F: physically impossible
                self.ctx.count("odometry_too_fast")
                self.ctx.warn_once(msg.t, "odometry_too_fast",
                                   f"a step of {step:.1f} m in {dt:.2f} s is faster than "
                                   f"{p.odometry.max_speed:g} m/s: replaced by the speed limit",
                                   agent=msg.agent)
                self.gen.add_relative_position(
                    key, prev.key, np.zeros(3),
                    np.diag([(p.odometry.max_speed * dt) ** 2] * 2 + [0.25]))
            else:
                extra = (p.odometry.noise_per_m * step) ** 2
                cov = cov + np.diag([extra, extra, 0.0]) + np.eye(3) * 1e-6
                if heading is None:
                    self.gen.add_relative_position(key, prev.key, delta, cov)
                else:
                    self.gen.add_rotated_position(key, prev.key, heading, delta, cov)
            walked = prev.path + min(step, p.odometry.max_speed * dt)
            self._grow_doubt(st, walked - prev.path)
            st.states.append(_State(key, msg.t, step / dt, heading, st.count - 1, walked))
            st.heading_var += float(np.asarray(msg.cov)[3, 3])
            self._release(msg.agent, st, final=False)
        self.gen.relinearize()
        self._forget_old(st)
        self._publish_pose(msg, st)
        self._publish_touched(msg.t)

    def _first_state(self, msg: Odometry, st: _Agent, rot: np.ndarray) -> None:
        p = self.params
        start = p.start.pose_of(msg.agent)[0] if p.start.mode == "pose" else None
        if start is None:
            start = rot @ (np.asarray(msg.position, float) - np.asarray(msg.delta, float))
        start = np.asarray(start, float)
        key = f"{msg.agent}@start"
        self.gen.add_node(key)
        base = self.gen.estimate(p.base.id)
        self.gen.add_relative_position(key, p.base.id, start - base,
                                       np.diag([p.start.sigma_position ** 2] * 2 + [0.1 ** 2]))
        st.doubt = p.start.sigma_position ** 2 if self._doubting else 0.0
        heading = None
        if p.heading.enabled:
            heading = f"{key}/heading"
            self.gen.add_node(heading)
            self.gen.add_linear([heading], np.eye(3), np.diag(
                [p.start.sigma_heading ** 2, p.heading.rate_sigma ** 2, p.heading.turn_scale_sigma ** 2]),
                np.zeros(3))
        st.states.append(_State(key, msg.t_start, 0.0, heading))

    def _heading_state(self, msg: Odometry, key: str, prev: _State) -> str:
        """The heading state of the step ending at ``msg.t``, from the previous one by
        ``psi_k = psi_k-1 + omega dt + kappa dtheta``, ``omega`` and ``kappa`` random walks.

        ``dtheta`` is the heading change the INS measured over the step; the heading's
        process noise is the INS's own heading variance of the step (which includes the
        errors its filter does not estimate).
        """
        p = self.params
        node = f"{key}/heading"
        self.gen.add_node(node)
        dt = max(msg.t - prev.t, 0.0)
        dtheta = wrap_angle(float(msg.dheading))
        F = np.array([[1.0, dt, dtheta], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
        q = np.diag([max(float(np.asarray(msg.cov)[3, 3]), 1e-10),
                     max(p.heading.rate_walk ** 2 * dt, 1e-14),
                     max(p.heading.turn_scale_walk ** 2, 1e-14)])
        self.gen.add_linear([node, prev.heading], np.hstack([np.eye(3), -F]), q, np.zeros(3))
        return node

    def _forget_old(self, st: _Agent) -> None:
        """Marginalise states beyond the window (§IV-E, DeleteNode eq. 17).

        Marginalising freezes the linearisation of a state's odometry (turned by its
        heading estimate), and a heading wrong by ``a`` then misplaces every later node by
        about ``a^2 / 2`` of the step: 5 % at 0.3 rad, typical before the first loop
        closure. So a state whose heading is still more uncertain than
        ``settle_heading_sigma`` stays (up to ``window_max`` states) until a closure has
        fixed it and its odometry has been re-linearised. At most
        ``graph.forget_per_update`` states go per update, so that the backlog a closure
        settles at once is spread over the next updates (a bounded cost per update).
        """
        p = self.params
        budget = p.graph.forget_per_update
        while len(st.states) > p.graph.window and budget > 0:
            budget -= 1
            old = st.states[0]
            if (old.heading is not None and len(st.states) <= p.graph.window_max
                    and self.gen.covariances_of([old.heading])[0, 0, 0]
                    > p.graph.settle_heading_sigma ** 2):
                self.ctx.count("states_kept_unsettled")
                return
            st.states.popleft()
            self.gen.delete_node(old.key)
            if old.heading is not None:
                self.gen.delete_node(old.heading)

    # -- radio -------------------------------------------------------------------------------------
    def _radio(self, msg: Range) -> None:
        p = self.params
        if msg.method == "rssi_encounter":
            if not p.radio.use_encounters:
                return
        elif not p.radio.use_ranges:
            return
        if not (math.isfinite(msg.range_m) and msg.range_m >= 0 and math.isfinite(msg.sigma_m)
                and msg.sigma_m > 0):
            self.ctx.count("range_invalid")
            return
        agents = [n for n in (msg.a, msg.b) if n in self._agents]
        if not agents:
            if msg.method == "rssi":
                self._static_range(msg)
            return
        # wait until the firefighter has a state at or after the reading
        self._agents[agents[0]].pending.append(msg)
        self._release(agents[0], self._agents[agents[0]], final=False)

    def _drop(self, msg: BreadcrumbDrop) -> None:
        if msg.node_id in self._crumbs:
            self._kicked(msg)
            return
        if not msg.agent:
            self.ctx.count("drop_without_agent")
            return
        st = self._agent(msg.agent)
        st.pending.append(msg)
        self._release(msg.agent, st, final=False)

    def _release(self, agent: str, st: _Agent, final: bool) -> None:
        """Apply the waiting events of ``agent`` whose time the state chain now covers."""
        if not st.states:
            if final and st.pending:  # no usable odometry ever came: say so, never silently
                self.ctx.count("events_without_odometry", len(st.pending))
                self.ctx.warn_once(st.pending[-1].t, "no_odometry",
                                   f"{agent}: {len(st.pending)} radio/drop event(s) unused: "
                                   "this firefighter has no usable odometry to place them on",
                                   agent=agent)
                st.pending = []
            return
        t_last = st.states[-1].t
        ready = [e for e in st.pending if e.t <= t_last or final]
        if not ready:
            return
        st.pending = [e for e in st.pending if not (e.t <= t_last or final)]
        with self.gen.batch():
            for ev in sorted(ready, key=lambda e: e.t):
                if isinstance(ev, BreadcrumbDrop):
                    self._apply_drop(ev, st)
                else:
                    self._apply_radio(ev, agent, st)

    def _state_at(self, st: _Agent, t: float) -> _State | None:
        """The state nearest ``t``, or None when it is more than ``time_match`` away."""
        best = _nearest_state(st, t)
        return best if abs(best.t - t) <= self.params.radio.time_match else None

    def _node_of(self, node: str, t: float) -> tuple[str, float, float] | None:
        """(graph node, antenna height, extra horizontal variance) of a radio node at ``t``."""
        p = self.params
        if node == p.base.id:
            return node, 0.0, 0.0
        if node in self._crumbs:
            return self._crumbs[node], p.breadcrumbs.antenna_height, 0.0
        st = self._agents.get(node)
        if st is None or not st.states:
            return None
        s = self._state_at(st, t)
        if s is None:
            return None
        return s.key, p.radio.agent_antenna_height, (s.speed * (s.t - t)) ** 2

    def _apply_radio(self, msg: Range, agent: str, st: _Agent) -> None:
        p = self.params
        a = self._node_of(msg.a, msg.t)
        b = self._node_of(msg.b, msg.t)
        if a is None or b is None:
            self.ctx.count("radio_unmatched")
            return
        if self._radio_model is not None:
            if msg.method == "rssi":
                self._learn(msg, agent, a, b)
            r, sigma = self._radio_model.correct(msg.range_m, msg.sigma_m)
            msg = replace(msg, range_m=r, sigma_m=sigma) if msg.method == "rssi" \
                else replace(msg, range_m=r)
        other = msg.b if msg.a == agent else msg.a
        mutual = other in self._agents
        if msg.method == "rssi_encounter":
            self._encounter(msg, agent, a, b, self._mutual_share(st, other, msg.t, mutual),
                            mutual)
            return
        if msg.t - st.last_range.get(other, -math.inf) < p.radio.period:
            self.ctx.count("range_thinned")
            return
        if msg.range_m > p.radio.max_range:
            self.ctx.count("range_too_long")
            return
        if not mutual and self._same_place(st, other, msg.t):
            self.ctx.count("range_same_place")
            return
        st.last_range[other] = msg.t
        self._range(msg, agent, a, b, self._mutual_share(st, other, msg.t, mutual), mutual)

    def _mutual_share(self, st: _Agent, other: str, t: float, mutual: bool) -> float:
        """The factor a link's variance enters with: 1 for a link to a fixed node; for a
        link between two firefighters, the number of their links within
        ``radio.mutual_correlation_s`` (this one included). Two firefighters walking
        together drift together: their repeated ranges and encounters share one error,
        so together they carry the information of one link, not of many."""
        window = self.params.radio.mutual_correlation_s
        if not mutual or window <= 0:
            return 1.0
        times = st.mutual.setdefault(other, deque())
        while times and t - times[0] > window:
            times.popleft()
        times.append(t)
        if len(times) > 1:
            self.ctx.count("mutual_links_shared")
        return float(len(times))

    def _same_place(self, st: _Agent, other: str, t: float) -> bool:
        """Whether a range to the fixed node ``other`` comes from within
        ``radio.shadow_length`` (walked, by the odometry) of the last one used: its
        shadowing is the same (fixed in space), so it adds nothing; a firefighter
        waiting by a breadcrumb or the base station gives one range, however long."""
        here = self._state_at(st, t)
        if here is None or self.params.radio.shadow_length <= 0:
            return False
        last = st.nearby.get(other)
        if last is not None and here.path - last < self.params.radio.shadow_length:
            return True
        st.nearby[other] = here.path
        return False

    def _learn(self, msg: Range, agent: str, a, b) -> None:
        """A link of known length for the path-loss model (radio_model.py): the base station
        over a firefighter's first ``learn.steps`` steps, a breadcrumb over its dropper's
        next ``learn.steps`` steps."""
        p = self.params
        (na, ha, _), (nb, hb, _) = a, b
        mine, fixed = (na, nb) if msg.a == agent else (nb, na)
        step = int(mine.rsplit("@", 1)[1]) if "@" in mine and mine[-1].isdigit() else -1
        if fixed == p.base.id:
            known = step <= p.learn.steps
        else:
            by = self._dropped_by.get(fixed)
            known = by is not None and by[0] == agent and 0 <= step - by[1] <= p.learn.steps
        link = (agent, fixed)
        if not known or msg.t - self._learnt_at.get(link, -math.inf) < p.learn.period:
            return
        self._learnt_at[link] = msg.t
        x = self.gen.estimates_of([na, nb])
        d = float(np.linalg.norm(x[0] - x[1] + np.array([0.0, 0.0, ha - hb])))
        was_ready = self._radio_model.ready
        self._radio_model.observe(msg.range_m, d)
        if self._radio_model.ready and not was_ready:
            c, e = self._radio_model.coefficients
            self.ctx.diagnose(msg.t, "info", "path_loss_learned",
                              f"radio model learned from {self._radio_model.samples} links "
                              f"of known length: log10 r = {c:+.3f} + {e:.3f} log10 d "
                              f"(exponent {e:.3f} x the sensor's, RSSI at 1 m the sensor's "
                              f"{-c * 10:+.1f} x its exponent dB; spread "
                              f"{self._radio_model.residual_sigma:.2f} decades)", agent=agent)

    def _encounter(self, msg: Range, agent: str, a, b, share: float = 1.0,
                   mutual: bool = False) -> None:
        (na, ha, va), (nb, hb, vb) = a, b
        var = msg.sigma_m ** 2
        if self._radio_model is not None and self._radio_model.ready:
            # the learned model says how far apart the nodes were at the peak
            var = max(var, max(msg.range_m ** 2 - (ha - hb) ** 2, 0.0) / 2.0)
        var = (max(var, self.params.radio.near_sigma ** 2) + va + vb) * share
        cov = np.diag([var, var, 0.3 ** 2])
        cov = self._judged_position(agent, msg.t, na, nb, np.zeros(3), cov, "encounter",
                                    absolute=not mutual)
        if cov is None:
            return
        self.gen.add_relative_position(na, nb, np.zeros(3), cov)
        self.ctx.count("encounters_used")
        self._touched.update((na, nb))

    def _judged_position(self, agent: str, t: float, na: str, nb: str, zeta: np.ndarray,
                         cov: np.ndarray, what: str, absolute: bool = True
                         ) -> np.ndarray | None:
        """The covariance a relative position ``zeta`` = x_a - x_b enters with, after
        judging its innovation against the graph (§IV-F, :meth:`_judge`); None: dropped.
        ``absolute`` False: a link between two firefighters, which checks only where
        they are relative to each other (see :meth:`_judge`)."""
        x = self.gen.estimates_of([na, nb])
        joint = self._relative_cov(na, nb)
        innov = zeta - (x[0] - x[1])
        S = joint[:2, :2] + cov[:2, :2]
        m2 = float(innov[:2] @ np.linalg.solve(S, innov[:2]))
        scale = self._judge(agent, t, math.sqrt(m2 / 2.0), m2 / 2.0,
                            float(np.hypot(innov[0], innov[1])), x[0], what, absolute)
        if scale is None:
            return None
        out = cov.copy()
        out[:2, :2] *= scale
        if absolute:
            self._narrow_doubt(agent, na, nb, float(out[0, 0]))
        return out

    @property
    def _doubting(self) -> bool:
        """Whether the doubt of ``consistency.doubt_per_m`` is kept."""
        c = self.params.consistency
        return c.enabled and c.doubt_per_m > 0

    def _grow_doubt(self, st: _Agent, walked: float) -> None:
        """The doubt's std per axis grows by ``consistency.doubt_per_m`` times the
        ``walked`` [m] of a step, whatever the graph's odometry model says of the step."""
        if self._doubting:
            st.doubt = (math.sqrt(st.doubt) + self.params.consistency.doubt_per_m * walked) ** 2

    def _narrow_doubt(self, agent: str, na: str, nb: str, var: float) -> None:
        """A firefighter placed at a fixed node by a link of horizontal variance ``var``
        [m^2] per axis: its doubt is fused with the link's variance plus the node's doubt
        (the base station's is 0, a breadcrumb's its dropper's at the drop), but not below
        the node's own: links from different places average their noise, never the
        node's error they share. Links between firefighters do not narrow it: they say
        nothing of where the pair is."""
        st = self._agents.get(agent)
        node = next((self._doubt[n] for n in (na, nb) if n in self._doubt), None)
        if st is None or node is None or not self._doubting:
            return
        v = node + var
        if st.doubt + v > 0:
            st.doubt = max(st.doubt * v / (st.doubt + v), min(st.doubt, node))

    def _judge(self, agent: str, t: float, z: float, nis: float, miss: float,
               where: np.ndarray, what: str, absolute: bool = True) -> float | None:
        """Judge a radio link whose innovation is ``z`` sigmas (``nis``: its squared
        normalised innovation per degree of freedom, ``miss`` [m] its size) and return
        the factor its variance enters with.

        Up to ``radio.weaken`` sigmas: as measured (1). To ``radio.gate``: weakened so it
        sits at ``weaken`` sigmas (§IV-F). Beyond: it contradicts the graph - down-weighted
        by a further ``(z / gate)^4`` (its pull falls as ``1 / z``), counted, said with the
        place, and the firefighter's published covariance carries ``miss^2`` until a later
        link confirms the graph (within ``weaken``: gone; within ``gate``: shrunk by
        ``consistency.widen_decay``). Without ``consistency.enabled`` (the paper) it is
        dropped (None).

        A link between two firefighters (``absolute`` False) agrees with the graph
        wherever the pair has drifted together, so it neither enters the running
        normalised innovation nor confirms the graph after a contradiction; it is still
        weakened, down-weighted and said as above.
        """
        p = self.params
        st = self._agents.get(agent) if p.consistency.enabled else None
        if st is not None and absolute:
            st.nis += (min(nis, 25.0) - st.nis) / p.consistency.memory
        if z <= p.radio.gate:                   # consistent with the graph
            if st is not None and absolute:
                st.contradicted = False
                st.widen = 0.0 if z <= p.radio.weaken else st.widen * p.consistency.widen_decay
            if z <= p.radio.weaken:
                return 1.0
            self.ctx.count(f"{what}s_weakened")
            return (z / p.radio.weaken) ** 2
        scale = (z / p.radio.weaken) ** 2
        self.ctx.count(f"{what}_contradictions")
        if not p.consistency.enabled:
            return None
        if st is not None:
            st.widen = max(st.widen, miss ** 2)
            st.contradicted = True
            st.unsaid += 1
            if t - st.last_said >= 10.0:
                self.ctx.diagnose(t, "warning", "radio_contradiction",
                                  f"{agent}: {st.unsaid} {what}(s) contradict the graph "
                                  f"(latest {z:.1f} sigma, {miss:.1f} m) near ({where[0]:.1f}, "
                                  f"{where[1]:.1f}) m: down-weighted, position widened",
                                  agent=agent)
                st.last_said, st.unsaid = t, 0
        return scale * (z / p.radio.gate) ** 4

    def _relative_cov(self, na: str, nb: str) -> np.ndarray:
        """Covariance (3, 3) of x_a - x_b."""
        free = [n for n in (na, nb) if not self.gen.is_anchor(n)]
        if not free:
            return np.zeros((3, 3))
        C = self.gen.joint_covariance(free)
        if len(free) == 1:
            return C
        return C[:3, :3] + C[3:, 3:] - C[:3, 3:] - C[3:, :3]

    def _range(self, msg: Range, agent: str, a, b, share: float = 1.0,
               mutual: bool = False) -> None:
        p = self.params
        (na, ha, va), (nb, hb, vb) = a, b
        absolute = not mutual
        off = np.array([0.0, 0.0, ha - hb])
        var = (msg.sigma_m ** 2 + va + vb) * share
        x = self.gen.estimates_of([na, nb])
        diff = x[0] - x[1] + off
        pred = float(np.linalg.norm(diff))
        rel = self._relative_cov(na, nb)
        spread = math.sqrt(max(rel[0, 0] + rel[1, 1], 0.0))
        if msg.range_m < p.radio.near_range or pred < spread:
            # the direction is meaningless here: "within r of each other"
            horiz = max(msg.range_m ** 2 - (ha - hb) ** 2, 0.0)
            v = max(horiz / 2.0, p.radio.near_sigma ** 2) + var
            cov = self._judged_position(agent, msg.t, na, nb, np.zeros(3),
                                        np.diag([v, v, 0.3 ** 2]), "range", absolute)
            if cov is None:
                return
            self.gen.add_relative_position(na, nb, np.zeros(3), cov)
            self.ctx.count("ranges_near")
            self._touched.update((na, nb))
            return
        h = diff / pred
        innov = msg.range_m - pred
        S = float(h @ rel @ h) + var
        z = abs(innov) / math.sqrt(S)
        scale = self._judge(agent, msg.t, z, z * z, abs(innov), x[0], "range", absolute)
        if scale is None:
            return
        self.gen.add_range(na, nb, msg.range_m, var * scale, offset=off)
        self.ctx.count("ranges_used")
        self._touched.update((na, nb))

    def _static_range(self, msg: Range) -> None:
        """Between two fixed nodes: one edge from the median of ``static_samples`` readings
        (their shadowing is fixed, so more readings would not add information)."""
        p = self.params
        fixed = [n for n in (msg.a, msg.b) if n == p.base.id or n in self._crumbs]
        if len(fixed) < 2:
            self.ctx.count("radio_unmatched")
            return
        na, nb = self._crumbs.get(msg.a, msg.a), self._crumbs.get(msg.b, msg.b)
        pair = tuple(sorted((na, nb)))
        got = self._static.setdefault(pair, [])
        if len(got) >= p.radio.static_samples:
            return
        got.append(msg.range_m)
        if len(got) < p.radio.static_samples:
            return
        r = float(np.median(got))
        if r > p.radio.max_range or not (self.gen.is_localised(na) and self.gen.is_localised(nb)):
            return
        sigma = msg.sigma_m * r / max(msg.range_m, 1e-6)
        ha = 0.0 if na == p.base.id else p.breadcrumbs.antenna_height
        hb = 0.0 if nb == p.base.id else p.breadcrumbs.antenna_height
        fake = Range(t=msg.t, a=na, b=nb, range_m=r, sigma_m=sigma, method="rssi")
        with self.gen.batch():
            self._range(fake, "", (na, ha, 0.0), (nb, hb, 0.0))
        self.gen.relinearize()

    # -- breadcrumbs -----------------------------------------------------------------------------
    def _apply_drop(self, msg: BreadcrumbDrop, st: _Agent) -> None:
        s = self._state_at(st, msg.t)
        if s is None:
            s = _nearest_state(st, msg.t)
            self.ctx.count("drop_time_unmatched")
        v = self.params.breadcrumbs.drop_sigma ** 2 + (s.speed * (s.t - msg.t)) ** 2
        self.gen.add_node(msg.node_id)
        self.gen.add_relative_position(msg.node_id, s.key, np.zeros(3), np.diag([v, v, 0.05]))
        self._crumbs[msg.node_id] = msg.node_id
        self._dropped_by[msg.node_id] = (msg.agent, s.index)
        self._doubt[msg.node_id] = st.doubt + v
        self._touched.add(msg.node_id)

    def _kicked(self, msg: BreadcrumbDrop) -> None:
        """A breadcrumb moved (§V-C): a new node, tied to the old one by ``kick_sigma``."""
        old = self._crumbs[msg.node_id]
        self._kicks[msg.node_id] = self._kicks.get(msg.node_id, 0) + 1
        new = f"{msg.node_id}#{self._kicks[msg.node_id]}"
        k = self.params.breadcrumbs.kick_sigma ** 2
        self.gen.add_node(new)
        self.gen.add_relative_position(new, old, np.zeros(3), np.diag([k, k, 0.05]))
        self._crumbs[msg.node_id] = new
        self._doubt[new] = self._doubt.get(old, 0.0) + k
        for pair in [pr for pr in self._static if old in pr]:
            del self._static[pair]                       # its fixed links start afresh
        self.ctx.count("breadcrumbs_relocated")
        self.ctx.diagnose(msg.t, "info", "breadcrumb_relocated",
                          f"breadcrumb {msg.node_id} moved: tracked as a new node {new}")

    # -- output ---------------------------------------------------------------------------------
    def _publish_pose(self, msg: Odometry, st: _Agent) -> None:
        state = st.states[-1]
        nodes = [state.key] if state.heading is None else [state.key, state.heading]
        x = self.gen.estimates_of(nodes)                 # one query for position and heading
        c = self.gen.covariances_of(nodes)
        if self.gen.rebuild_pending:
            self.ctx.count("poses_while_refactorising")
        cov = np.zeros((4, 4))
        cov[:3, :3] = c[0]
        heading = msg.heading + self.params.odometry.rotation.get(msg.agent, 0.0)
        if state.heading is None:
            cov[3, 3] = st.heading_var
        else:
            heading += float(x[1, 0])
            cov[3, 3] = float(c[1, 0, 0])
        # the graph's marginal, scaled by how far its radio innovations say it is
        # optimistic, widened by a contradiction not yet resolved and by the doubt
        cov[:2, :2] = cov[:2, :2] * max(st.nis, 1.0) + np.eye(2) * (st.widen + st.doubt)
        ip = self.params.integrity
        pr = gaussian_protection_radius(cov[:2, :2], ip.containment)
        self.ctx.publish("pose", PoseEstimate(
            t=msg.t, agent=msg.agent, device=msg.device, position=x[0],
            heading=wrap_angle(heading), cov=cov, protection_radius=pr,
            trusted=trusted(pr, ip, st.contradicted)))

    def _publish_touched(self, t: float) -> None:
        crumbs = self._crumb_ids()
        nodes = [n for n in self._touched if n in crumbs]
        self._touched.clear()
        self._publish_crumbs(t, nodes, crumbs)

    def _crumb_ids(self) -> dict[str, str]:
        """Current graph node -> breadcrumb id (the inverse of ``_crumbs``)."""
        return {node: bc for bc, node in self._crumbs.items()}

    def _publish_crumbs(self, t: float, nodes: list[str], crumbs: dict[str, str]) -> None:
        if not nodes:
            return
        nodes = sorted(nodes)
        x = self.gen.estimates_of(nodes)
        c = self.gen.covariances_of(nodes)
        for k, node in enumerate(nodes):
            cov = np.zeros((4, 4))
            cov[:3, :3] = c[k]
            cov[3, 3] = math.pi ** 2
            pr = gaussian_protection_radius(cov[:2, :2], self.params.integrity.containment)
            self.ctx.publish("breadcrumbs", PoseEstimate(
                t=t, agent=crumbs[node], device=node, position=x[k], heading=0.0, cov=cov,
                protection_radius=pr, trusted=trusted(pr, self.params.integrity)))

    def finish(self) -> None:
        self.gen.finish_rebuild()
        for agent, st in self._agents.items():
            self._release(agent, st, final=True)
        t = max((st.states[-1].t for st in self._agents.values() if st.states), default=0.0)
        crumbs = self._crumb_ids()
        self._publish_crumbs(t, list(crumbs), crumbs)
        self.ctx.count("graph_rebuilds", self.gen.solver.rebuilds)
        for name in ("background_rebuilds", "waited_handovers", "late_handovers"):
            if getattr(self.gen, name):
                self.ctx.count(f"graph_{name}", getattr(self.gen, name))


def _nearest_state(st: _Agent, t: float) -> _State:
    return min(st.states, key=lambda s: abs(s.t - t))
