"""The fused output recorded as MCAP in Foxglove's well-known schemas, one topic per
firefighter (the topics: :mod:`.foxglove_topics`).

Foxglove's Map panel draws the location fixes of a georeferenced plan, its 3D panel
the poses and the walls of every floor; the ``mcap`` CLI and the ``mcap`` Python
reader list the schema names (``foxglove.PoseInFrame``, ``foxglove.LocationFix``,
``foxglove.SceneUpdate``, ``foxglove.Log``, ``firenav.*`` JSON schemas). ``log_time``
is the message time ``t`` in nanoseconds (times before 0 are written as 0 and counted
as ``negative_times``). The incident log (alarm events and acknowledgements, from the
``live_view`` sink's diagnostics) is the topic ``/incident_log``.

Crash safety: chunks are small (``chunk_kb``) and the file is flushed every
``flush_s`` seconds of wall time, so a killed run leaves every finished chunk
readable by a streaming MCAP reader (the summary at the end is missing).
"""
from __future__ import annotations

import math
import time
import typing

import numpy as np

from ..contract import FileSink, OutputName, Params, param
from ..messages import Message
from .foxglove_topics import FoxgloveTopics, Record


class McapRecorderSink(FileSink):
    """Record poses (Foxglove PoseInFrame, LocationFix), walls, diagnostics and any stream to MCAP."""

    name = "mcap_recorder"
    inputs = (Message,)

    class Params(Params):
        file: OutputName = param("fused.mcap")
        """file name under the output folder"""
        compression: typing.Literal["zstd", "lz4", "none"] = param("zstd")
        """chunk compression"""
        chunk_kb: int = param(64, gt=0, le=65536, unit="KiB")
        """chunk size: a crash can lose at most the chunk being filled"""
        flush_s: float = param(0.5, gt=0, unit="s")
        """flush to the operating system at least this often (wall time)"""
        wall_clock: bool = param(True)
        """incident-log entries carry the wall-clock time they were written ('wall')"""

    def start(self) -> None:
        from mcap.writer import CompressionType, Writer
        self._fh = open(self.out_path(self.params.file), "wb")
        comp = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4,
                "none": CompressionType.NONE}[self.params.compression]
        self._writer = Writer(self._fh, chunk_size=self.params.chunk_kb * 1024,
                              compression=comp)
        self._writer.start(profile="", library="firenav")
        self.topics = FoxgloveTopics.of_context(self.ctx, wall_clock=self.params.wall_clock)
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, int] = {}
        self._seq: dict[str, int] = {}
        self._plan_written = False
        self._next_flush = time.monotonic() + self.params.flush_s

    def _channel(self, rec: Record) -> int:
        cid = self._channels.get(rec.topic)
        if cid is None:
            sid = self._schemas.get(rec.schema_name)
            if sid is None:
                sid = self._schemas[rec.schema_name] = self._writer.register_schema(
                    name=rec.schema_name, encoding=rec.schema_encoding, data=rec.schema_data)
            cid = self._channels[rec.topic] = self._writer.register_channel(
                topic=rec.topic, message_encoding=rec.message_encoding, schema_id=sid)
        return cid

    def _write(self, rec: Record) -> None:
        seq = self._seq[rec.topic] = self._seq.get(rec.topic, 0) + 1
        self._writer.add_message(self._channel(rec), log_time=rec.log_time,
                                 publish_time=rec.log_time, sequence=seq, data=rec.data)

    def handle(self, stream: str, msg: Message) -> None:
        if math.isfinite(msg.t) and msg.t < 0:
            self.ctx.count("negative_times")
        if not self._plan_written:  # the walls, at the time of the first message
            self._plan_written = True
            for rec in self.topics.building_records(msg.t):
                self._write(rec)
        for rec in self.topics.records(stream, msg):
            self._write(rec)
        now = time.monotonic()
        if now >= self._next_flush:
            self._next_flush = now + self.params.flush_s
            self._fh.flush()

    def finish(self) -> None:
        self._writer.finish()
        self._fh.close()
