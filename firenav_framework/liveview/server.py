"""The commander's page over HTTP: a small standard-library server in daemon threads.

Routes: ``/`` the page (``index.html``, ``app.js``, ``style.css``), ``/api/building``
the floor plan (encoded once), ``/api/state`` the latest snapshot in full, ``/events``
Server-Sent Events (the full state first, then one delta per snapshot), and
``POST /api/ack`` (``{"id": <alarm id>, "by": "<name>"}``) to acknowledge an alarm.
Every request passes the Host check and the token (:mod:`.access`) first.

The server reads only immutable snapshots of the :class:`~.feed.ViewFeed`; nothing a
client does takes a lock the pipeline needs. Acknowledgements go into a queue the
``live_view`` sink drains on the pipeline thread (the alarm book is the pipeline's).
"""
from __future__ import annotations

import json
import logging
import queue
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from importlib import resources
from typing import Any, NamedTuple
from urllib.parse import parse_qs, urlsplit

from .access import Access
from .feed import ViewFeed

log = logging.getLogger("firenav.liveview")

__all__ = ["LiveViewServer", "Ack", "MAX_CLIENTS", "MAX_BODY"]

STATIC = {"/": ("index.html", "text/html; charset=utf-8"),
          "/index.html": ("index.html", "text/html; charset=utf-8"),
          "/app.js": ("app.js", "text/javascript; charset=utf-8"),
          "/style.css": ("style.css", "text/css; charset=utf-8")}
MAX_CLIENTS = 64    # concurrent /events connections
MAX_BODY = 4096     # bytes of an acknowledgement request


class Ack(NamedTuple):
    """One acknowledgement from the page: the alarm, who (as typed), the client's
    address and the wall clock of the click [UNIX s]."""

    alarm_id: int
    by: str
    client: str
    wall: float


class LiveViewServer:
    """Serves the page and the snapshots; see the module docstring."""

    def __init__(self, feed: ViewFeed, building: dict, title: str, host: str, port: int,
                 access: Access, keepalive_s: float = 5.0):
        self.feed = feed
        self.building = json.dumps(building, separators=(",", ":")).encode()
        self.title = title
        self.access = access
        self.keepalive_s = keepalive_s
        self.acks: queue.SimpleQueue[Ack] = queue.SimpleQueue()
        self.refused = {"host": 0, "token": 0, "origin": 0, "busy": 0, "bad_request": 0}
        self._clients = threading.BoundedSemaphore(MAX_CLIENTS)
        self.httpd = ThreadingHTTPServer((host, port), _make_handler(self))
        self.httpd.daemon_threads = True
        self.thread = threading.Thread(target=self.httpd.serve_forever, name="live-view",
                                       daemon=True)

    @property
    def url(self) -> str:
        host, port = self.httpd.server_address[:2]
        host = "127.0.0.1" if host in ("0.0.0.0", "") else host
        return f"http://{host}:{port}/"

    def start(self) -> None:
        self.thread.start()

    def close(self) -> None:
        self.httpd.shutdown()
        self.httpd.server_close()


def _make_handler(server: LiveViewServer) -> type[BaseHTTPRequestHandler]:
    feed, access = server.feed, server.access

    class Handler(BaseHTTPRequestHandler):
        protocol_version = "HTTP/1.1"
        timeout = 60.0  # a client that stops reading is dropped, its thread freed

        def log_message(self, fmt: str, *args: Any) -> None:
            log.debug("%s " + fmt, self.address_string(), *args)

        def _send(self, body: bytes, ctype: str, status: int = 200,
                  headers: dict[str, str] | None = None) -> None:
            self.send_response(status)
            self.send_header("Content-Type", ctype)
            self.send_header("Content-Length", str(len(body)))
            self.send_header("Cache-Control", "no-store")
            self.send_header("X-Content-Type-Options", "nosniff")
            for k, v in (headers or {}).items():
                self.send_header(k, v)
            self.end_headers()
            self.wfile.write(body)

        def _refuse(self, why: str, status: int, text: str) -> None:
            server.refused[why] += 1
            self._send(text.encode(), "text/plain; charset=utf-8", status)

        def _admitted(self, query_token: str | None = None) -> bool:
            if not access.host_ok(self.headers.get("Host")):
                self._refuse("host", 421, "unknown host name: this field kit answers to "
                             "its own address only (DNS rebinding protection)\n")
                return False
            if not access.token_ok(self.headers.get("Authorization"),
                                   self.headers.get("Cookie"), query_token):
                self._refuse("token", 401, "login required: open the address with its "
                             "token as printed by the field kit (…/?token=…)\n")
                return False
            return True

        def do_GET(self) -> None:  # noqa: N802 (http.server's name)
            url = urlsplit(self.path)
            query_token = (parse_qs(url.query).get("token") or [None])[0]
            if not self._admitted(query_token if url.path == "/" else None):
                return
            if url.path == "/" and query_token:  # logged in: keep the token out of the URL
                self._send(b"", "text/plain", 303, {"Location": "/",
                                                    "Set-Cookie": access.cookie_header()})
            elif url.path in STATIC:
                name, ctype = STATIC[url.path]
                self._send(resources.files(__package__).joinpath(name).read_bytes(), ctype)
            elif url.path == "/api/building":
                self._send(server.building, "application/json")
            elif url.path == "/api/state":
                self._full_state()
            elif url.path == "/events":
                self._events()
            else:
                self._send(b"not found\n", "text/plain", 404)

        def do_POST(self) -> None:  # noqa: N802
            if not self._admitted():
                return
            if not access.origin_ok(self.headers.get("Origin")):
                self._refuse("origin", 403, "acknowledgements come from the kit's own page\n")
                return
            if urlsplit(self.path).path != "/api/ack":
                self._send(b"not found\n", "text/plain", 404)
                return
            try:
                n = int(self.headers.get("Content-Length") or -1)
                if not 0 < n <= MAX_BODY:
                    raise ValueError(f"a body of 1..{MAX_BODY} bytes is needed")
                body = json.loads(self.rfile.read(n))
                alarm_id = body["id"]
                by = str(body.get("by", ""))[:64]
                if isinstance(alarm_id, bool) or not isinstance(alarm_id, int):
                    raise ValueError("id must be an alarm number")
            except (ValueError, KeyError, TypeError) as exc:
                self._refuse("bad_request", 400, f"bad acknowledgement: {exc}\n")
                return
            server.acks.put(Ack(alarm_id, by, self.client_address[0], time.time()))
            self._send(b'{"queued":true}', "application/json", 202)

        def _full_state(self) -> None:
            parts = feed.snapshot.full_parts(b'"title":' + json.dumps(server.title).encode()
                                             + b",")
            self.send_response(200)
            self.send_header("Content-Type", "application/json")
            self.send_header("Content-Length", str(sum(map(len, parts))))
            self.send_header("Cache-Control", "no-store")
            self.end_headers()
            for p in parts:
                self.wfile.write(p)

        def _events(self) -> None:
            if not server._clients.acquire(blocking=False):
                self._refuse("busy", 503, f"more than {MAX_CLIENTS} live views are open\n")
                return
            try:
                self.send_response(200)
                self.send_header("Content-Type", "text/event-stream")
                self.send_header("Cache-Control", "no-store")
                self.send_header("Connection", "close")
                self.end_headers()
                self.close_connection = True
                self._stream()
            except (BrokenPipeError, ConnectionResetError, TimeoutError):
                pass
            finally:
                server._clients.release()

        def _stream(self) -> None:
            seq = -1
            while not feed.closing:
                snap = feed.wait_after(seq, server.keepalive_s)
                if snap.seq == seq:
                    self.wfile.write(b": keep-alive\n\n")
                else:
                    deltas = feed.deltas_after(seq, snap) if seq >= 0 else None
                    if deltas is None:  # first event, or too far behind: everything
                        self.wfile.write(b"data: ")
                        for p in snap.full_parts():
                            self.wfile.write(p)
                        self.wfile.write(b"\n\n")
                    else:
                        for d in deltas:
                            self.wfile.write(b"data: " + d + b"\n\n")
                    seq = snap.seq
                self.wfile.flush()

    return Handler
