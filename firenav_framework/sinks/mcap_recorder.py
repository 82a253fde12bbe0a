"""The fused output (poses, covariances, diagnostics, any stream) recorded as MCAP.

One MCAP channel per input stream (topic = the stream name, e.g. ``ins.pose``), JSON
messages with a JSON-schema per message type generated from the message dataclass,
so Foxglove Studio, the ``mcap`` CLI and the ``mcap`` Python reader show them with
field names. Arrays become nested lists, bytes base64, non-finite floats ``null``.
``log_time`` is the message time ``t`` in nanoseconds (times before 0 are written as
0 and counted as ``negative_times``).

Crash safety: chunks are small (``chunk_kb``) and the file is flushed every
``flush_s`` seconds of wall time, so a killed run leaves every finished chunk
readable by a streaming MCAP reader (the summary at the end is missing).
"""
from __future__ import annotations

import base64
import dataclasses
import json
import math
import time
import typing

import numpy as np

from ..contract import FileSink, OutputName, Params, param
from ..messages import Message

_JSON_TYPES = {float: {"type": ["number", "null"]}, int: {"type": "integer"},
               str: {"type": "string"}, bool: {"type": "boolean"}}


def _field_schema(tp: typing.Any) -> dict:
    origin = typing.get_origin(tp)
    args = [a for a in typing.get_args(tp) if a is not type(None)]
    if origin in (typing.Union, getattr(__import__("types"), "UnionType", None)):
        inner = [_field_schema(a) for a in args]
        return {"anyOf": inner + [{"type": "null"}]}
    if tp in _JSON_TYPES:
        return dict(_JSON_TYPES[tp])
    if tp is bytes:
        return {"type": "string", "contentEncoding": "base64"}
    if tp is np.ndarray:
        return {"type": "array", "description": "numpy array as nested lists"}
    return {}


def json_schema(cls: type[Message]) -> dict:
    """A JSON schema of a message dataclass (field names, types, the docstring)."""
    hints = typing.get_type_hints(cls)
    props = {f.name: _field_schema(hints.get(f.name)) for f in dataclasses.fields(cls)}
    return {"title": f"firenav.{cls.__name__}", "description": (cls.__doc__ or "").strip(),
            "type": "object", "properties": props}


def _jsonable(value: typing.Any) -> typing.Any:
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, (bytes, bytearray)):
        return base64.b64encode(bytes(value)).decode()
    if isinstance(value, np.generic):
        return _jsonable(value.item())
    return value


def _clean(obj: typing.Any) -> typing.Any:
    """Non-finite floats in nested lists become None (JSON has no NaN)."""
    if isinstance(obj, list):
        return [_clean(v) for v in obj]
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def message_json(msg: Message) -> bytes:
    """The JSON body of one message (see the module docstring)."""
    body = {f.name: _clean(_jsonable(getattr(msg, f.name))) for f in dataclasses.fields(msg)}
    return json.dumps(body, separators=(",", ":"), allow_nan=False).encode()


class McapRecorderSink(FileSink):
    """Record streams (poses with covariance, diagnostics, ...) to an MCAP file for robotics tools."""

    name = "mcap_recorder"
    inputs = (Message,)

    class Params(Params):
        file: OutputName = param("fused.mcap", description="file name under the output folder")
        compression: typing.Literal["zstd", "lz4", "none"] = param(
            "zstd", description="chunk compression")
        chunk_kb: int = param(64, gt=0, le=65536, unit="KiB", description="chunk size: a crash can "
                              "lose at most the chunk being filled")
        flush_s: float = param(0.5, gt=0, unit="s", description="flush to the operating "
                               "system at least this often (wall time)")

    def start(self) -> None:
        from mcap.writer import CompressionType, Writer
        self._fh = open(self.out_path(self.params.file), "wb")
        comp = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4,
                "none": CompressionType.NONE}[self.params.compression]
        self._writer = Writer(self._fh, chunk_size=self.params.chunk_kb * 1024,
                              compression=comp)
        self._writer.start(profile="", library="firenav")
        self._schemas: dict[type, int] = {}
        self._channels: dict[str, int] = {}
        self._seq: dict[str, int] = {}
        self._next_flush = time.monotonic() + self.params.flush_s

    def _channel(self, stream: str, msg: Message) -> int:
        cid = self._channels.get(stream)
        if cid is None:
            cls = type(msg)
            sid = self._schemas.get(cls)
            if sid is None:
                sid = self._schemas[cls] = self._writer.register_schema(
                    name=f"firenav.{cls.__name__}", encoding="jsonschema",
                    data=json.dumps(json_schema(cls)).encode())
            cid = self._channels[stream] = self._writer.register_channel(
                topic=stream, message_encoding="json", schema_id=sid,
                metadata={"message_kind": cls.kind})
        return cid

    def handle(self, stream: str, msg: Message) -> None:
        cid = self._channel(stream, msg)
        t_ns = round(msg.t * 1e9) if math.isfinite(msg.t) else 0
        if t_ns < 0:
            self.ctx.count("negative_times")
            t_ns = 0
        seq = self._seq[stream] = self._seq.get(stream, 0) + 1
        self._writer.add_message(cid, log_time=t_ns, publish_time=t_ns, sequence=seq,
                                 data=message_json(msg))
        now = time.monotonic()
        if now >= self._next_flush:
            self._next_flush = now + self.params.flush_s
            self._fh.flush()

    def finish(self) -> None:
        self._writer.finish()
        self._fh.close()

