"""The commander's live view in the browser, served by the field kit (localhost by default).

On the pipeline thread the sink keeps the conditions (:mod:`..liveview.status`) and the
latched alarms (:mod:`..liveview.alarms`), publishes every alarm event and every
acknowledgement on its ``diagnostics`` port (the incident log: route
``<id>.diagnostics`` to ``diagnostics_log`` and ``mcap_recorder``), and hands small
items to the view's feed; the snapshot thread and the web server do everything else
(:mod:`..liveview.feed`, :mod:`..liveview.server`). It measures the time the pipeline
spends in it per message (``waits()``, :class:`~..liveview.feed.WaitMeter`; counted as
``waits_over_bound`` when a message held it up longer than ``wait_bound``).
"""
from __future__ import annotations

import json
import math
import os
import queue
import sys
import time

import numpy as np

from ..contract import NoBuilding, Sink, param
from ..liveview.access import Access
from ..liveview.alarms import ALARM_CODES, AlarmBook, AlarmEvent, alarm_diagnostic
from ..liveview.feed import ViewFeed, WaitMeter, finite
from ..liveview.plan import building_json
from ..liveview.server import LiveViewServer
from ..liveview.status import AgentStatus, StatusParams, StatusTracker
from ..messages import Diagnostic, PoseEstimate, Tick

#: Diagnostic codes of link health, which the page lists apart from alarms.
LINK_CODES = frozenset({"device_silent", "gap"})
TOKEN_ENV = "FIRENAV_LIVE_VIEW_TOKEN"


def diagnostic_category(code: str) -> str:
    """``alarm``, ``link`` (link health: link_*, device_silent, timeline gaps) or ``other``."""
    if code in ALARM_CODES:
        return "alarm"
    if code.startswith("link_") or code in LINK_CODES:
        return "link"
    return "other"


class LiveViewSink(Sink):
    """Browser view: floor plan, tracks, protection radii, latched alarms with acknowledgement, timeline."""

    name = "live_view"
    inputs = (PoseEstimate, Diagnostic)

    class Params(StatusParams):
        host: str = param("127.0.0.1")
        """address to serve on (localhost by default; on a network set a token and allowed_hosts)"""
        port: int = param(8765, ge=0, le=65535)
        """TCP port (0: any free port)"""
        allowed_hosts: list[str] = param([])
        """host names the page may be reached by besides the loopback names and the listening
        address (DNS rebinding protection)"""
        token: str = param("", description="login token the page needs (also from the "
                           f"environment variable {TOKEN_ENV}); empty: no login")
        push_period: float = param(0.25, unit="s", gt=0)
        """at most one browser update this often"""
        max_points: int = param(20000, gt=0)
        """track points kept per firefighter (whole chunks of 1000)"""
        wait_bound: float = param(0.05, unit="s", gt=0)
        """a message that keeps the pipeline in this sink longer is counted"""

    @classmethod
    def tick_period(cls, params: Params) -> float:
        return 1.0  # the condition clock and the acknowledgements advance with the timeline

    def start(self) -> None:
        p = self.params
        self.tracker = StatusTracker.from_params(p)
        self.book = AlarmBook()
        self.meter = WaitMeter(p.wait_bound)
        self.feed = ViewFeed(period=p.push_period, max_points=p.max_points)
        self._sent: dict[str, dict] = {}
        try:
            plan = building_json(self.ctx.building)
        except NoBuilding:  # tracks on a blank grid
            plan = building_json(None)
        token = p.token or os.environ.get(TOKEN_ENV, "")
        self.server = LiveViewServer(self.feed, plan, plan.get("name") or "firenav",
                                     p.host, p.port, Access(p.host, p.allowed_hosts, token))
        self.feed.start()
        self.server.start()
        self.url = self.server.url
        login = f"?token={token}" if token else ""
        print(f"[firenav] live view: {self.url}{login}", file=sys.stderr, flush=True)
        if p.host not in ("127.0.0.1", "localhost", "::1") and not token:
            self.ctx.warn_once(0.0, "live_view_open", f"the live view listens on {p.host} "
                               "without a token: anyone on that network can open it")

    # ------------------------------------------------------------------ pipeline thread
    def handle(self, stream: str, msg) -> None:
        t_in, cpu_in = time.perf_counter(), time.process_time()
        lock = 0.0
        while True:
            try:
                ack = self.server.acks.get_nowait()
            except queue.Empty:
                break
            lock = max(lock, self._acknowledge(ack, msg.t))
        if isinstance(msg, PoseEstimate):
            lock = max(lock, self._pose(msg))
        elif isinstance(msg, Diagnostic):
            lock = max(lock, self._diagnostic(msg))
        elif isinstance(msg, Tick):
            lock = max(lock, self._tick(msg.t))
        over = self.meter.over
        self.meter.record(time.perf_counter() - t_in, time.process_time() - cpu_in, lock)
        if self.meter.over > over:
            self.ctx.count("waits_over_bound")

    def waits(self) -> dict:
        """The pipeline's time in this sink so far (see :class:`~..liveview.feed.WaitMeter`)."""
        return self.meter.as_dict()

    def _pose(self, msg: PoseEstimate) -> float:
        if not msg.agent:
            self.ctx.count("poses_without_agent")
            return 0.0
        changes = self.tracker.pose(msg)
        p = msg.position
        if not np.all(np.isfinite(p[:2])):
            self.ctx.count("non_finite_poses")
            lock = 0.0
        else:
            lock = self.feed.put(("pose", msg.agent, msg.t,
                                  (finite(p[0]), finite(p[1]), finite(p[2]), msg.floor,
                                   0 if msg.trusted else 1)))
        return max(lock, self._agent(msg.agent), self._alarms(changes, msg.t))

    def _diagnostic(self, msg: Diagnostic) -> float:
        lock = self._view_diag(msg)
        return max(lock, self._alarms(self.tracker.diagnostic(msg), msg.t))

    def _tick(self, t: float) -> float:
        changes = self.tracker.clock(t)
        lock = self.feed.put(("now", t))
        for agent in self.tracker.agents:
            lock = max(lock, self._agent(agent))
        return max(lock, self._alarms(changes, t))

    def _view_diag(self, d: Diagnostic) -> float:
        return self.feed.put(("diag", {"t": d.t, "level": d.level, "code": d.code,
                                       "agent": d.agent, "component": d.component,
                                       "text": d.text, "active": d.active,
                                       "category": diagnostic_category(d.code)}))

    def _agent(self, agent: str) -> float:
        item = json.dumps(_agent_json(self.tracker.agents[agent], self.tracker),
                          separators=(",", ":"), allow_nan=False).encode()
        if self._sent.get(agent) == item:
            return 0.0
        self._sent[agent] = item
        return self.feed.put(("agent", agent, item))

    def _where(self) -> dict:
        out = {}
        for agent, st in self.tracker.agents.items():
            pos = None
            if st.pose is not None and np.all(np.isfinite(st.pose.position[:2])):
                pos = (float(st.pose.position[0]), float(st.pose.position[1]))
            out[agent] = (st.pose.floor if st.pose is not None else None, pos)
        return out

    def _alarms(self, changes: list, t: float) -> float:
        if not changes:
            return 0.0
        return self._events(self.book.update(changes, t, self._where()))

    def _events(self, events: list[AlarmEvent]) -> float:
        lock = 0.0
        for ev in events:
            diag = alarm_diagnostic(ev, self.ctx.id)
            self.ctx.publish("diagnostics", diag)
            lock = max(lock, self._view_diag(diag))
        if events:
            lock = max(lock, self.feed.put(("alarms", [a.as_json() for a in self.book.shown()])))
        return lock

    def _acknowledge(self, ack, t: float) -> float:
        alarm_id, by, client, wall = ack
        t_now = self.tracker.now if math.isfinite(self.tracker.now) else t
        ev = self.book.acknowledge(alarm_id, t_now, wall, by=by, client=client)
        if isinstance(ev, str):
            self.ctx.count("acknowledgements_refused")
            return self._view_diag(Diagnostic(t=t_now, component=self.ctx.id, level="info",
                                              code="alarm_ack_refused", text=ev))
        return self._events([ev])

    def finish(self) -> None:
        while not self.server.acks.empty():  # acknowledged after the last message
            self._acknowledge(self.server.acks.get_nowait(), self.tracker.now)
        self.feed.publish()
        self.server.close()
        self.feed.close()


def _agent_json(st: AgentStatus, tracker: StatusTracker) -> dict:
    """One firefighter as the page shows it (ENU metres, radians, pipeline seconds)."""
    item = {"agent": st.agent, "conditions": dict(st.conditions),
            "stale": st.stale(tracker.now, tracker.stale_after),
            "silent_devices": sorted(st.silent_devices)}
    if st.pose is not None:
        pose = st.pose
        p, c = pose.position, pose.cov
        item.update(t=finite(pose.t), x=finite(p[0]), y=finite(p[1]), z=finite(p[2]),
                    heading=finite(pose.heading), floor=pose.floor, trusted=bool(pose.trusted),
                    frame=pose.frame, protection_radius=finite(pose.protection_radius),
                    cov=[[finite(c[0, 0]), finite(c[0, 1])], [finite(c[1, 0]), finite(c[1, 1])]])
    return item
