"""A live Foxglove WebSocket server: the MCAP recorder's topics (:mod:`.foxglove_topics`)
streamed to the Foxglove app while the incident runs ("Open connection" ->
"Foxglove WebSocket" -> ``ws://127.0.0.1:8766``).

The server is Foxglove's own (``foxglove.start_server`` of the foxglove-sdk, its Rust
core in its own threads, with a context of this sink only). It listens on loopback
by default and has no login: reach it from another machine through an SSH tunnel, not
by listening on the network. Logging a message hands its bytes to the SDK, which
queues them per client (``backlog`` messages, the oldest dropped beyond), so a slow
client never holds up the pipeline. The walls (``/building``) are sent again every
``plan_every`` seconds of data time, for clients that connect later.
"""
from __future__ import annotations

import sys

from ..contract import Params, Sink, param
from ..messages import Message
from .foxglove_topics import FoxgloveTopics, Record

_LOOPBACK = ("127.0.0.1", "localhost", "::1")


class FoxgloveLiveSink(Sink):
    """Serve the fused output live to the Foxglove app over its WebSocket protocol (loopback)."""

    name = "foxglove_live"
    inputs = (Message,)

    class Params(Params):
        host: str = param("127.0.0.1")
        """address to listen on (loopback: the server has no login)"""
        port: int = param(8766, ge=0, le=65535)
        """TCP port (0: any free port; 8765 is the live view's)"""
        backlog: int = param(1024, gt=0)
        """messages queued per client before the oldest are dropped"""
        plan_every: float = param(10.0, unit="s", gt=0)
        """send the walls again this often (data time), for clients that join later"""

    def start(self) -> None:
        import foxglove
        self.topics = FoxgloveTopics.of_context(self.ctx)
        self._fg = foxglove
        self._context = foxglove.Context()
        self._channels: dict[str, object] = {}
        self._plan_at: float | None = None
        if self.params.host not in _LOOPBACK:
            self.ctx.warn_once(0.0, "foxglove_live_open", f"the Foxglove server listens on "
                               f"{self.params.host} without a login")
        self.server = foxglove.start_server(name=f"firenav {self.ctx.id}", host=self.params.host,
                                            port=self.params.port, context=self._context,
                                            message_backlog_size=self.params.backlog)
        self.url = f"ws://{self.params.host}:{self.server.port}"
        print(f"[firenav] Foxglove WebSocket: {self.url}", file=sys.stderr, flush=True)

    def _log(self, rec: Record) -> None:
        ch = self._channels.get(rec.topic)
        if ch is None:
            schema = self._fg.Schema(name=rec.schema_name, encoding=rec.schema_encoding,
                                     data=rec.schema_data)
            ch = self._channels[rec.topic] = self._fg.Channel(
                rec.topic, schema=schema, message_encoding=rec.message_encoding,
                context=self._context)
        ch.log(rec.data, log_time=rec.log_time)

    def handle(self, stream: str, msg: Message) -> None:
        if self.topics.building is not None and (
                self._plan_at is None or not msg.t - self._plan_at < self.params.plan_every):
            self._plan_at = msg.t
            for rec in self.topics.building_records(msg.t):
                self._log(rec)
        for rec in self.topics.records(stream, msg):
            self._log(rec)

    def finish(self) -> None:
        self.server.stop()
