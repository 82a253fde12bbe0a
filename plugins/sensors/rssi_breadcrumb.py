"""RSSI breadcrumb radio: ranges from a path-loss model, encounters, moved breadcrumbs.

Breadcrumb radios (2.4 GHz, breadcrumb paper §III, §V) report the RSSI of every packet
heard from another node: the base station, a dropped breadcrumb or a firefighter's
radio (node id = the agent id). This sensor turns that traffic into measurements for a
relative measurement graph:

* ``range`` - every plausible reading as a :class:`Range` (``method="rssi"``) through the
  log-distance model ``RSSI = P_1m - 10 n log10(d) + X``, ``X ~ N(0, sigma_dB^2)``
  inverted as ``d = 10^((P_1m - RSSI) / (10 n))``. Its standard deviation grows with the
  range (delta method on the log): ``sigma_d = d sigma_dB ln(10) / (10 n)``.
* ``encounters`` - a firefighter passing a node (§V-A: the RSSI rises above about -40 dBm,
  i.e. within about a metre; "points with local optimum are considered as the positions
  where encounters occur"). One encounter per episode above ``encounter_dbm``, at the
  episode's peak, published once the RSSI has fallen ``encounter_hysteresis_db`` below
  the peak (or the link went quiet). Message: :class:`Range` with
  ``method="rssi_encounter"``, ``t`` the peak time, ``range_m`` the model range at the
  peak and ``sigma_m`` = ``encounter_sigma_m`` (the estimator reads it as "the two nodes
  were at the same place, within sigma_m per axis").
* ``moved`` - a breadcrumb that was kicked (§V-C: moved 1-2 m). The links between fixed
  nodes (breadcrumbs, base station) keep a steady RSSI; when the median of a node's
  links to at least ``kick_min_links`` other fixed nodes shifts by more than ``kick_db``
  while those nodes' other links stay put, the node has moved. Published as a
  :class:`BreadcrumbDrop` of the already-dropped node id (``agent`` empty, ``device``
  ``"kick_detector"``) at the time the change began: "this node was placed anew".

Impossible readings are counted and skipped, never passed on: RSSI above
``max_rssi_dbm`` (0 dBm: no receiver reads more than a transmitter sends at 2.4 GHz
short range) or below ``min_rssi_dbm``, non-finite values, a node hearing itself,
unknown node ids and breadcrumbs that have not been dropped yet (still in the dispenser).
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

import numpy as np

from firenav_framework import BreadcrumbDrop, Params, Range, RssiReading, Sensor, param

LN10 = math.log(10.0)


def rssi_to_range(rssi_dbm: float, rssi_1m_dbm: float, exponent: float) -> float:
    """Range [m] of the log-distance path-loss model for an RSSI [dBm]."""
    return 10.0 ** ((rssi_1m_dbm - rssi_dbm) / (10.0 * exponent))


def range_sigma(range_m: float, shadowing_db: float, exponent: float) -> float:
    """Standard deviation [m] of a model range: ``d sigma_dB ln(10) / (10 n)``."""
    return range_m * shadowing_db * LN10 / (10.0 * exponent)


@dataclass
class _Episode:
    """An encounter episode of one pair: RSSI above the threshold, peak so far."""

    peak_dbm: float
    peak_t: float
    agent: str
    device: str


@dataclass
class _Link:
    """Recent RSSI of a link between two fixed nodes, for the kick detector."""

    reference: float | None = None
    recent: deque = field(default_factory=deque)   # (t, rssi)
    changed_at: float | None = None


class RssiBreadcrumbSensor(Sensor):
    """Breadcrumb radio traffic -> RSSI ranges, encounter events and moved breadcrumbs."""

    name = "rssi_breadcrumb"
    inputs = (RssiReading, BreadcrumbDrop)
    outputs = {"range": Range, "encounters": Range, "moved": BreadcrumbDrop}

    class Params(Params):
        rssi_1m_dbm: float = param(-40.0, unit="dBm", description="RSSI at 1 m (breadcrumb "
                                   "paper §V-A: above -40 dBm within about a metre)")
        path_loss_exponent: float = param(3.0, gt=1, lt=6, description="log-distance "
                                          "exponent n (indoor 2.4 GHz: 2.5-3.5; calibrate)")
        shadowing_db: float = param(5.0, unit="dB", gt=0, description="std of the RSSI about "
                                    "the model (shadowing + fading); sets the range sigma")
        min_range_m: float = param(0.3, unit="m", gt=0, description="model ranges are "
                                   "clipped up to this")
        max_range_m: float = param(30.0, unit="m", gt=0, description="readings implying a "
                                   "longer range carry no useful range and are skipped "
                                   "(counted)")
        max_rssi_dbm: float = param(0.0, unit="dBm", description="above this a reading is "
                                    "impossible")
        min_rssi_dbm: float = param(-110.0, unit="dBm", description="below this a reading "
                                    "is impossible (under any receiver's sensitivity)")
        base_stations: list[str] = param(["base"], description="node ids of base stations "
                                         "(fixed nodes known from the start)")
        encounter_dbm: float = param(-40.0, unit="dBm", description="an encounter episode "
                                     "is RSSI at or above this (§V-A)")
        encounter_hysteresis_db: float = param(3.0, unit="dB", ge=0, description="the peak "
                                               "is confirmed once the RSSI falls this far "
                                               "below it")
        encounter_max_gap_s: float = param(3.0, unit="s", gt=0, description="an episode "
                                           "ends when the link is quiet this long")
        encounter_sigma_m: float = param(1.0, unit="m", gt=0, description="position "
                                         "agreement of an encounter, per axis")
        kick_db: float = param(6.0, unit="dB", gt=0, description="shift of a fixed link's "
                               "median RSSI that says a node moved")
        kick_window: int = param(8, ge=3, description="readings per median of a fixed link")
        kick_min_links: int = param(2, ge=1, description="fixed links of a node that must "
                                    "shift together")

    def __init__(self, params: Params, ctx) -> None:
        super().__init__(params, ctx)
        p = self.params
        self._fixed: dict[str, float] = {b: -math.inf for b in p.base_stations}  # id -> t
        self._agents: set[str] = set()
        self._episodes: dict[tuple[str, str], _Episode] = {}
        self._last_heard: dict[tuple[str, str], float] = {}
        self._links: dict[tuple[str, str], _Link] = {}
        self._warned: set[str] = set()

    # -- input ------------------------------------------------------------------------------
    def handle(self, stream: str, msg) -> None:
        if isinstance(msg, BreadcrumbDrop):
            if msg.agent:
                self._agents.add(msg.agent)
            if msg.node_id not in self._fixed:
                self._fixed[msg.node_id] = msg.t
            return
        if isinstance(msg, RssiReading):
            self._reading(msg)

    def _reading(self, msg: RssiReading) -> None:
        p = self.params
        if msg.agent:
            self._agents.add(msg.agent)
        rssi = msg.rssi_dbm
        problem = self._problem(msg)
        if problem:
            self.ctx.count(problem)
            return
        d = rssi_to_range(rssi, p.rssi_1m_dbm, p.path_loss_exponent)
        pair = tuple(sorted((msg.tx, msg.rx)))
        if msg.tx in self._fixed and msg.rx in self._fixed:
            self._kick_check(pair, msg.t, rssi)
        else:
            self._encounter(pair, msg, rssi)
        if d > p.max_range_m:
            self.ctx.count("beyond_max_range")
            return
        d = max(d, p.min_range_m)
        self.ctx.publish("range", Range(t=msg.t, agent=msg.agent, device=msg.device,
                                        a=msg.tx, b=msg.rx, range_m=d,
                                        sigma_m=range_sigma(d, p.shadowing_db,
                                                            p.path_loss_exponent),
                                        method="rssi"))

    def _problem(self, msg: RssiReading) -> str:
        """Why a reading is impossible ('' when it is plausible); counted by that name."""
        p = self.params
        rssi = msg.rssi_dbm
        if not isinstance(rssi, (int, float)) or not math.isfinite(rssi):
            return "rejected_non_finite"
        if rssi > p.max_rssi_dbm:
            return "rejected_rssi_too_high"
        if rssi < p.min_rssi_dbm:
            return "rejected_rssi_too_low"
        if msg.tx == msg.rx:
            return "rejected_self_reading"
        for node in (msg.tx, msg.rx):
            if node in self._agents:
                continue
            t_drop = self._fixed.get(node)
            if t_drop is None:
                self._warn(msg.t, node, f"RSSI readings name node {node!r}, which is neither "
                           "a base station, a dropped breadcrumb nor a firefighter: skipped")
                return "rejected_unknown_node"
            if msg.t < t_drop:
                return "rejected_not_dropped_yet"
        return ""

    def _warn(self, t: float, node: str, text: str) -> None:
        if node not in self._warned:
            self._warned.add(node)
            self.ctx.diagnose(t, "warning", "unknown_radio_node", text)

    # -- encounters (§V-A) -------------------------------------------------------------------
    def _encounter(self, pair: tuple[str, str], msg: RssiReading, rssi: float) -> None:
        p = self.params
        ep = self._episodes.get(pair)
        last = self._last_heard.get(pair)
        self._last_heard[pair] = msg.t
        if ep is not None and last is not None and msg.t - last > p.encounter_max_gap_s:
            self._emit(pair, ep)
            ep = None
        if rssi >= p.encounter_dbm:
            if ep is None:
                agent = msg.agent or next((n for n in pair if n in self._agents), "")
                self._episodes[pair] = _Episode(rssi, msg.t, agent, msg.device)
            elif rssi > ep.peak_dbm:
                ep.peak_dbm, ep.peak_t = rssi, msg.t
        elif ep is not None and rssi <= ep.peak_dbm - p.encounter_hysteresis_db:
            self._emit(pair, ep)

    def _emit(self, pair: tuple[str, str], ep: _Episode) -> None:
        p = self.params
        self._episodes.pop(pair, None)
        d = max(rssi_to_range(ep.peak_dbm, p.rssi_1m_dbm, p.path_loss_exponent), p.min_range_m)
        a, b = ((ep.agent, pair[1] if pair[0] == ep.agent else pair[0])
                if ep.agent in pair else pair)
        self.ctx.count("encounters")
        self.ctx.publish("encounters", Range(t=ep.peak_t, agent=ep.agent, device=ep.device,
                                             a=a, b=b, range_m=d, sigma_m=p.encounter_sigma_m,
                                             method="rssi_encounter"))

    # -- kicked breadcrumbs (§V-B/C) -----------------------------------------------------------
    def _kick_check(self, pair: tuple[str, str], t: float, rssi: float) -> None:
        p = self.params
        link = self._links.setdefault(pair, _Link())
        link.recent.append((t, rssi))
        if len(link.recent) > p.kick_window:
            link.recent.popleft()
        if len(link.recent) < p.kick_window:
            return
        level = float(np.median([r for _, r in link.recent]))
        if link.reference is None:
            link.reference = level
            return
        if abs(level - link.reference) > p.kick_db and link.changed_at is None:
            link.changed_at = link.recent[0][0]
            self._attribute(pair[0])
            self._attribute(pair[1])

    def _attribute(self, node: str) -> None:
        """Declare ``node`` moved when enough of its fixed links shifted and the peers'
        other links did not (so it is this node, not a peer, that moved)."""
        p = self.params
        if node in self.params.base_stations:
            return
        mine = {pair: link for pair, link in self._links.items() if node in pair}
        shifted = {pair: link for pair, link in mine.items() if link.changed_at is not None}
        if len(shifted) < min(p.kick_min_links, len(mine)) or not shifted:
            return
        if len(mine) == 1 and len(self._links) > 1:
            return        # one link only: cannot tell which end moved
        for pair in shifted:
            peer = pair[0] if pair[1] == node else pair[1]
            peer_other = [lk for pr, lk in self._links.items() if peer in pr and node not in pr]
            if peer_other and all(lk.changed_at is not None for lk in peer_other):
                return    # the peer's links moved too: not this node's doing
        t0 = min(link.changed_at for link in shifted.values())
        for link in mine.values():          # new reference levels after the move
            link.reference = float(np.median([r for _, r in link.recent]))
            link.changed_at = None
        self.ctx.count("breadcrumbs_moved")
        self.ctx.diagnose(t0, "warning", "breadcrumb_moved",
                          f"breadcrumb {node} moved (RSSI of {len(shifted)} fixed links "
                          f"shifted by more than {p.kick_db:g} dB)")
        self.ctx.publish("moved", BreadcrumbDrop(t=t0, agent="", device="kick_detector",
                                                 node_id=node))

    def finish(self) -> None:
        for pair, ep in list(self._episodes.items()):
            self._emit(pair, ep)


PLUGINS = [RssiBreadcrumbSensor]
