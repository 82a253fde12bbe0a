"""The ``rssi_breadcrumb`` sensor class: radio readings in; ranges, encounters, moves out."""
from __future__ import annotations

import math
from typing import ClassVar

from firenav_framework import BreadcrumbDrop, Params, Range, RawFrame, RssiReading, Sensor, param
from firenav_framework.codecs import FrameError
from firenav_framework.codecs.breadcrumb_lines import RadioEvent, radio_message
from firenav_framework.codecs.selection import CodecSelection, TransportCodecs
from firenav_framework.contract import Context

from .encounters import EncounterDetector, EncounterRules, Episode
from .kicks import KickDetector, KickRules
from .path_loss import range_sigma, rssi_to_range

__all__ = ["RssiBreadcrumbSensor"]


class Frames(CodecSelection):
    """Codecs of the RawFrame inputs, per link transport."""

    record: ClassVar[type] = RadioEvent

    codecs: dict[str, str] = param({"serial": "breadcrumb_lines", "udp": "breadcrumb_lines"})
    """link transport -> codec decoding the radio network's lines (docs/formats/breadcrumb-
    radio.md)"""


class RssiBreadcrumbSensor(Sensor):
    """Breadcrumb radio traffic -> RSSI ranges, encounter events and moved breadcrumbs."""

    name = "rssi_breadcrumb"
    inputs = (RssiReading, BreadcrumbDrop, RawFrame)
    outputs = {"range": Range, "encounters": Range, "moved": BreadcrumbDrop,
               "drops": BreadcrumbDrop}
    #: A dropped breadcrumb stays where it fell: reset(agent) keeps it, so the same drop
    #: again is not published twice.
    world_outputs = ("drops",)

    class Params(Params):
        rssi_1m_dbm: float = param(-40.0, unit="dBm")
        """RSSI at 1 m (breadcrumb paper §V-A: above -40 dBm within about a metre)"""
        path_loss_exponent: float = param(3.0, gt=1, lt=6)
        """log-distance exponent n (indoor 2.4 GHz: 2.5-3.5; calibrate)"""
        shadowing_db: float = param(5.0, unit="dB", gt=0)
        """std of the RSSI about the model (shadowing + fading); sets the range sigma"""
        min_range_m: float = param(0.3, unit="m", gt=0)
        """model ranges are clipped up to this"""
        max_range_m: float = param(30.0, unit="m", gt=0)
        """readings implying a longer range carry no useful range and are skipped (counted)"""
        max_rssi_dbm: float = param(0.0, unit="dBm")
        """above this a reading is impossible"""
        min_rssi_dbm: float = param(-110.0, unit="dBm")
        """below this a reading is impossible (under any receiver's sensitivity)"""
        base_stations: list[str] = param(["base"])
        """node ids of base stations (fixed nodes known from the start)"""
        encounter: EncounterRules = param(EncounterRules())
        """encounter episodes (§V-A): threshold, peak, sigma"""
        kick: KickRules = param(KickRules())
        """moved-breadcrumb detection on the links between fixed nodes (§V-B/C)"""
        silent_s: float = param(60.0, unit="s", gt=0)
        """a dropped breadcrumb nobody has heard for this long is reported silent (a dud if never
        heard; burned or lost if it fell silent)"""
        frames: Frames = param(Frames())
        """RawFrame inputs: the codec per transport and its options"""

    def __init__(self, params: Params, ctx: Context) -> None:
        super().__init__(params, ctx)
        p = self.params
        self._fixed: dict[str, float] = {b: -math.inf for b in p.base_stations}  # id -> t
        self._agents: set[str] = set()
        self._encounters = EncounterDetector(p.encounter)
        self._kicks = KickDetector(p.kick, p.base_stations)
        self._heard: dict[str, float] = {}      # breadcrumb -> t it was last heard [s]
        self._link_t: dict[tuple[str, str], float] = {}   # node pair -> its last reading [s]
        self._silent: set[str] = set()          # breadcrumbs reported silent
        self._checked = -math.inf
        self._codecs = TransportCodecs(p.frames, count=ctx.count, resolve=ctx.resolve)

    # -- input ------------------------------------------------------------------------------
    def handle(self, stream: str, msg) -> None:
        if isinstance(msg, RawFrame):
            for event in self._decode(msg):
                self.handle(stream, radio_message(event))
        elif isinstance(msg, BreadcrumbDrop):
            if msg.agent:
                self._agents.add(msg.agent)
            if msg.node_id not in self._fixed:
                self._fixed[msg.node_id] = msg.t
                self.ctx.publish("drops", msg)
        elif isinstance(msg, RssiReading):
            self._reading(msg)

    def _decode(self, frame: RawFrame) -> list[RadioEvent]:
        """The radio events of a frame; broken lines are counted and reported once,
        other devices' lines counted (``other_lines``)."""
        try:
            return self._codecs.decode(frame) or []
        except FrameError as exc:
            self.ctx.count(exc.code)
            self.ctx.warn_once(frame.t, "radio_bad_line", f"{frame.device or 'radio link'}: "
                               f"{exc} (further broken lines are only counted)")
            return []

    def _reading(self, msg: RssiReading) -> None:
        p = self.params
        if msg.agent:
            self._agents.add(msg.agent)
        rssi = msg.rssi_dbm
        problem = self._problem(msg)
        if problem:
            self.ctx.count(problem)
            return
        pair = tuple(sorted((msg.tx, msg.rx)))
        last = self._link_t.get(pair)
        if last is not None and msg.t < last:
            # encounter peaks and kick medians follow each link forward in time: an older
            # reading cannot join them
            self.ctx.count("out_of_order")
            self.ctx.warn_once(msg.t, "rssi_out_of_order", f"RSSI reading {pair[0]}-{pair[1]} "
                               f"at t={msg.t:.3f} s is older than the link's last "
                               f"({last:.3f} s): dropped (counted as out_of_order)",
                               key="-".join(pair))
            return
        self._link_t[pair] = msg.t
        for node in (msg.tx, msg.rx):
            self._heard[node] = msg.t
            self._silent.discard(node)
        self._check_silent(msg.t)
        d = rssi_to_range(rssi, p.rssi_1m_dbm, p.path_loss_exponent)
        if msg.tx in self._fixed and msg.rx in self._fixed:
            for node, t0, links in self._kicks.reading(pair, msg.t, rssi):
                self._moved(node, t0, links)
        else:
            agent = msg.agent or next((n for n in pair if n in self._agents), "")
            for done in self._encounters.reading(pair, msg.t, rssi, agent, msg.device):
                self._emit(*done)
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
                self.ctx.warn_once(msg.t, "unknown_radio_node", f"RSSI readings name node "
                                   f"{node!r}, which is neither a base station, a dropped "
                                   "breadcrumb nor a firefighter: skipped", key=node)
                return "rejected_unknown_node"
            if msg.t < t_drop:
                return "rejected_not_dropped_yet"
        return ""

    def _check_silent(self, t: float) -> None:
        """Report, once, each dropped breadcrumb nobody has heard for ``silent_s`` while the
        radio traffic goes on: a dud that never transmitted, or one that burned or was
        lost. Its links simply stop; the estimator keeps what it learned before."""
        if t - self._checked < 5.0:
            return
        self._checked = t
        limit = self.params.silent_s
        for node, t_drop in self._fixed.items():
            if node in self.params.base_stations or node in self._silent:
                continue
            last = self._heard.get(node)
            if t - (t_drop if last is None else last) < limit:
                continue
            self._silent.add(node)
            self.ctx.count("breadcrumbs_silent")
            what = ("never heard since its drop (a dud)" if last is None
                    else f"silent since t = {last:.0f} s (burned or lost)")
            self.ctx.diagnose(t, "warning", "breadcrumb_silent",
                              f"breadcrumb {node}: {what}")

    def _emit(self, pair: tuple[str, str], ep: Episode) -> None:
        p = self.params
        d = max(rssi_to_range(ep.peak_dbm, p.rssi_1m_dbm, p.path_loss_exponent), p.min_range_m)
        a, b = ((ep.agent, pair[1] if pair[0] == ep.agent else pair[0])
                if ep.agent in pair else pair)
        self.ctx.count("encounters")
        self.ctx.publish("encounters", Range(t=ep.peak_t, agent=ep.agent, device=ep.device,
                                             a=a, b=b, range_m=d, sigma_m=p.encounter.sigma_m,
                                             method="rssi_encounter"))

    def _moved(self, node: str, t0: float, links: int) -> None:
        self.ctx.count("breadcrumbs_moved")
        self.ctx.diagnose(t0, "warning", "breadcrumb_moved",
                          f"breadcrumb {node} moved (RSSI of {links} fixed links "
                          f"shifted by more than {self.params.kick.db:g} dB)")
        self.ctx.publish("moved", BreadcrumbDrop(t=t0, agent="", device="kick_detector",
                                                 node_id=node))

    def finish(self) -> None:
        for done in self._encounters.close_all():
            self._emit(*done)
