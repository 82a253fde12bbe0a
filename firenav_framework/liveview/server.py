"""What the commander's page shows, and the HTTP server that shows it.

:class:`ViewState` is written by the ``live_view`` sink (pipeline thread) and read by
the server's threads under one lock. The page loads ``/api/state`` once, then follows
``/events`` (Server-Sent Events): every event carries the status of every firefighter,
the track points and diagnostics added since the previous event of that connection.
Only the standard library is used; the server listens on localhost unless told
otherwise, because it has no authentication.
"""
from __future__ import annotations

import json
import logging
import math
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from importlib import resources
from typing import Any

from ..messages import Diagnostic, PoseEstimate
from .status import StatusTracker

log = logging.getLogger("firenav.liveview")

STATIC = {"/": ("index.html", "text/html; charset=utf-8"),
          "/index.html": ("index.html", "text/html; charset=utf-8"),
          "/app.js": ("app.js", "text/javascript; charset=utf-8"),
          "/style.css": ("style.css", "text/css; charset=utf-8")}


def _num(v: float) -> float | None:
    return float(v) if math.isfinite(v) else None


def building_json(building: Any) -> dict:
    """Walls and doors per floor of a building model, for drawing (metres, ENU)."""
    if building is None:
        return {"floors": []}
    floors = []
    for f in building.floors:
        floors.append({"index": f.index, "name": f.name or f"floor {f.index}",
                       "walls": [[[round(float(v), 3) for v in p] for p in seg] for seg in f.walls],
                       "doors": [[[round(float(v), 3) for v in p] for p in d.jambs]
                                 for d in f.doors]})
    return {"name": getattr(building, "name", ""), "floors": floors}


class ViewState:
    """Tracks, statuses and diagnostics, with cursors for incremental updates."""

    def __init__(self, tracker: StatusTracker, *, max_points: int = 20000,
                 max_diagnostics: int = 500):
        self.tracker = tracker
        self.max_points = max_points
        self.max_diagnostics = max_diagnostics
        self.cond = threading.Condition()
        self.version = 0
        self.points: dict[str, list[list]] = {}
        self.dropped: dict[str, int] = {}  # points trimmed from the front, per agent
        self.diags: list[dict] = []
        self.diag_seq = 0
        self.building: dict = {"floors": []}
        self.title = "firenav"

    def _changed(self) -> None:
        self.version += 1
        self.cond.notify_all()

    def add_pose(self, msg: PoseEstimate) -> None:
        with self.cond:
            self.tracker.pose(msg)
            p = msg.position
            pts = self.points.setdefault(msg.agent, [])
            pts.append([round(msg.t, 3), round(float(p[0]), 3), round(float(p[1]), 3),
                        round(float(p[2]), 3), msg.floor])
            if len(pts) > self.max_points:
                cut = len(pts) - self.max_points
                del pts[:cut]
                self.dropped[msg.agent] = self.dropped.get(msg.agent, 0) + cut
            self._changed()

    def add_diagnostic(self, msg: Diagnostic) -> None:
        with self.cond:
            changes = self.tracker.diagnostic(msg)
            self._diag(msg.t, msg.level, msg.code, msg.agent, msg.component, msg.text,
                       msg.active)
            self._flag_changes(changes)
            self._changed()

    def tick(self, t: float) -> None:
        with self.cond:
            changes = self.tracker.clock(t)
            self._flag_changes(changes)
            if changes:
                self._changed()

    def _flag_changes(self, changes: list[tuple[str, str, bool]]) -> None:
        for agent, flag, on in changes:
            self._diag(self.tracker.now, "error" if on else "info", f"status_{flag}", agent,
                       "live_view", f"{agent}: {flag.replace('_', ' ')} "
                       f"{'since' if on else 'cleared at'} t={self.tracker.now:.1f} s", on)

    def _diag(self, t, level, code, agent, component, text, active) -> None:
        self.diag_seq += 1
        self.diags.append({"seq": self.diag_seq, "t": t, "level": level, "code": code,
                           "agent": agent, "component": component, "text": text,
                           "active": active})
        if len(self.diags) > self.max_diagnostics:
            del self.diags[:len(self.diags) - self.max_diagnostics]

    def agents_json(self) -> list[dict]:
        out = []
        for name, st in sorted(self.tracker.agents.items()):
            item: dict[str, Any] = {"agent": name, "flags": dict(st.flags),
                                    "silent_devices": sorted(st.silent_devices)}
            if st.pose is not None:
                p, c = st.pose.position, st.pose.cov
                item.update(t=_num(st.pose.t), x=_num(p[0]), y=_num(p[1]), z=_num(p[2]),
                            heading=_num(st.pose.heading), floor=st.pose.floor,
                            trusted=st.pose.trusted,
                            cov=[[_num(c[0, 0]), _num(c[0, 1])], [_num(c[1, 0]), _num(c[1, 1])]])
            out.append(item)
        return out

    def delta(self, cursor: dict) -> dict:
        """Everything new since ``cursor`` (updated in place); the caller holds the lock."""
        seen = cursor.setdefault("points", {})
        tracks = {}
        for agent, pts in self.points.items():
            start = seen.get(agent, 0) - self.dropped.get(agent, 0)
            new = pts[max(0, start):]
            if new:
                tracks[agent] = new
            seen[agent] = self.dropped.get(agent, 0) + len(pts)
        last = cursor.get("diag", 0)
        diags = [d for d in self.diags if d["seq"] > last]
        cursor["diag"] = self.diag_seq
        return {"version": self.version, "now": _num(self.tracker.now),
                "agents": self.agents_json(), "tracks": tracks, "diagnostics": diags}


class LiveViewServer:
    """Serves the page and the state over HTTP in daemon threads."""

    def __init__(self, state: ViewState, host: str, port: int, push_period: float = 0.25):
        self.state = state
        self.push_period = push_period
        self._closing = threading.Event()
        handler = _make_handler(self)
        self.httpd = ThreadingHTTPServer((host, port), handler)
        self.httpd.daemon_threads = True
        self.thread = threading.Thread(target=self.httpd.serve_forever, name="live-view",
                                       daemon=True)

    @property
    def url(self) -> str:
        host, port = self.httpd.server_address[:2]
        return f"http://{host}:{port}/"

    def start(self) -> None:
        self.thread.start()

    def close(self) -> None:
        self._closing.set()
        with self.state.cond:
            self.state.cond.notify_all()
        self.httpd.shutdown()
        self.httpd.server_close()


def _make_handler(server: LiveViewServer) -> type[BaseHTTPRequestHandler]:
    state = server.state

    class Handler(BaseHTTPRequestHandler):
        def log_message(self, fmt: str, *args: Any) -> None:
            log.debug("%s " + fmt, self.address_string(), *args)

        def _send(self, body: bytes, ctype: str, status: int = 200) -> None:
            self.send_response(status)
            self.send_header("Content-Type", ctype)
            self.send_header("Content-Length", str(len(body)))
            self.send_header("Cache-Control", "no-store")
            self.end_headers()
            self.wfile.write(body)

        def do_GET(self) -> None:  # noqa: N802 (http.server's name)
            path = self.path.split("?", 1)[0]
            if path in STATIC:
                name, ctype = STATIC[path]
                body = resources.files(__package__).joinpath(name).read_bytes()
                self._send(body, ctype)
            elif path == "/api/state":
                with state.cond:
                    body = {"title": state.title, "building": state.building,
                            **state.delta({})}
                self._send(json.dumps(body).encode(), "application/json")
            elif path == "/events":
                self._events()
            else:
                self._send(b"not found", "text/plain", 404)

        def _events(self) -> None:
            self.send_response(200)
            self.send_header("Content-Type", "text/event-stream")
            self.send_header("Cache-Control", "no-store")
            self.end_headers()
            cursor: dict = {}
            version = -1
            try:
                while not server._closing.is_set():
                    with state.cond:
                        state.cond.wait_for(lambda: state.version != version
                                            or server._closing.is_set(), timeout=5.0)
                        if state.version == version:
                            payload = None
                        else:
                            version = state.version
                            payload = json.dumps(state.delta(cursor))
                    if payload is None:
                        self.wfile.write(b": keep-alive\n\n")
                    else:
                        self.wfile.write(b"data: " + payload.encode() + b"\n\n")
                    self.wfile.flush()
                    server._closing.wait(server.push_period)
            except (BrokenPipeError, ConnectionResetError):
                pass

    return Handler
