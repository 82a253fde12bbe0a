"""Our messages as Foxglove topics: the well-known schemas Foxglove's panels draw, plus
JSON for everything else. Shared by ``mcap_recorder`` (a file) and ``foxglove_live``
(a WebSocket server), so both carry the same topics.

Encoding of the well-known schemas is Foxglove's own (the ``foxglove-sdk`` package:
``foxglove.messages.*.encode()`` and ``get_schema()``, protobuf with the schema names
``foxglove.PoseInFrame``, ...), so what we write is what Foxglove reads. Topics:

``/<stream>/<agent>``
    the whole :class:`PoseEstimate` as JSON (covariance 4x4, floor, trust, protection
    radius; schema ``firenav.PoseEstimate``), one topic per firefighter;
``/<stream>/<agent>/pose``
    ``foxglove.PoseInFrame`` in ``frame_id`` = the pose's frame (``building`` or the
    estimator's own), orientation the heading about +z (ENU);
``/<stream>/<agent>/fix``
    ``foxglove.LocationFix`` (WGS84 through the plan's georef; covariance East-North-Up
    in m^2, row-major) when the plan is georeferenced and the pose in the building;
``/building``
    ``foxglove.SceneUpdate``: one entity per floor (``floor<i>``), walls as a line list
    at the floor's level, doors and openings in their colours, in frame ``building``;
``/diagnostics``
    ``foxglove.Log`` of every diagnostic (name = component, level from ours);
``/incident_log``
    the alarm events and acknowledgements (codes ``alarm_*``) as JSON
    (``firenav.IncidentLogEntry``: pipeline time, local clock and, with ``wall_clock``,
    the wall-clock time written);
``/<stream>`` or ``/<stream>/<agent>``
    any other message as JSON with a schema generated from its dataclass (arrays as
    nested lists, bytes base64, non-finite floats null), per firefighter when it has
    an agent (diagnostics stay on their stream).

Times: Foxglove ``Timestamp`` and the MCAP log time are the pipeline time ``t`` (UNIX
seconds on a live link); a time before 0 becomes 0 (the caller counts it).
"""
from __future__ import annotations

import base64
import dataclasses
import functools
import json
import math
import types
import typing
from dataclasses import dataclass
from datetime import datetime
from typing import Any

import numpy as np

from ..liveview.alarms import ALARM_CODES
from ..liveview.plan import true_turn
from ..messages import Diagnostic, Message, PoseEstimate
from ..timefmt import clock_text

__all__ = ["Record", "FoxgloveTopics", "json_schema", "message_json", "INCIDENT_SCHEMA"]

_JSON_TYPES = {float: {"type": ["number", "null"]}, int: {"type": "integer"},
               str: {"type": "string"}, bool: {"type": "boolean"}}
_LOG_LEVEL = {"info": "Info", "warning": "Warning", "error": "Error"}

INCIDENT_SCHEMA = {
    "title": "firenav.IncidentLogEntry",
    "description": "An alarm event or acknowledgement of the commander's view "
                   "(firenav_framework/liveview/alarms.py)",
    "type": "object",
    "properties": {"t": {"type": "number", "description": "pipeline time [s]"},
                   "when": {"type": "string", "description": "t on the local clock"},
                   "code": {"type": "string"}, "agent": {"type": "string"},
                   "level": {"type": "string"}, "active": {"type": "boolean"},
                   "component": {"type": "string"}, "text": {"type": "string"},
                   "wall": {"type": "string", "description": "local wall-clock time the "
                            "entry was written (ISO 8601 with the UTC offset)"}}}


def _field_schema(tp: Any) -> dict:
    origin = typing.get_origin(tp)
    args = [a for a in typing.get_args(tp) if a is not type(None)]
    if origin in (typing.Union, types.UnionType):
        return {"anyOf": [_field_schema(a) for a in args] + [{"type": "null"}]}
    if tp in _JSON_TYPES:
        return dict(_JSON_TYPES[tp])
    if tp is bytes:
        return {"type": "string", "contentEncoding": "base64"}
    if tp is np.ndarray:
        return {"type": "array", "description": "numpy array as nested lists"}
    return {}


@functools.lru_cache(maxsize=None)
def json_schema(cls: type[Message]) -> dict:
    """A JSON schema of a message dataclass (field names, types, the docstring); do not
    change the (cached) result."""
    hints = typing.get_type_hints(cls)
    props = {f.name: _field_schema(hints.get(f.name)) for f in dataclasses.fields(cls)}
    return {"title": f"firenav.{cls.__name__}", "description": (cls.__doc__ or "").strip(),
            "type": "object", "properties": props}


def _jsonable(value: Any) -> Any:
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, np.ndarray):
        return _clean(value.tolist())
    if isinstance(value, (bytes, bytearray)):
        return base64.b64encode(bytes(value)).decode()
    if isinstance(value, np.generic):
        return _jsonable(value.item())
    return value


def _clean(obj: Any) -> Any:
    """Non-finite floats in nested lists become None (JSON has no NaN)."""
    if isinstance(obj, list):
        return [_clean(v) for v in obj]
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def message_json(msg: Message) -> bytes:
    """The JSON body of one message (see the module docstring)."""
    body = {f.name: _jsonable(getattr(msg, f.name)) for f in dataclasses.fields(msg)}
    return json.dumps(body, separators=(",", ":"), allow_nan=False).encode()


@dataclass(frozen=True)
class Record:
    """One message for one topic: its schema (name, encoding, bytes), the message
    encoding and data, and the log time [ns]."""

    topic: str
    schema_name: str
    schema_encoding: str
    schema_data: bytes
    message_encoding: str
    data: bytes
    log_time: int


_SCHEMA_BYTES: dict[str, bytes] = {}


def _schema_bytes(title: str, schema: dict) -> bytes:
    """The encoded JSON schema, once per schema title."""
    data = _SCHEMA_BYTES.get(title)
    if data is None:
        data = _SCHEMA_BYTES[title] = json.dumps(schema).encode()
    return data


def _ns(t: float) -> int:
    return max(0, round(t * 1e9)) if math.isfinite(t) else 0


class FoxgloveTopics:
    """Turns messages into :class:`Record` s (see the module docstring).

    ``building``: the plan (or None), for ``/building`` and, with its georef, the
    location fixes.
    """

    def __init__(self, building: Any = None, *, wall_clock: bool = False):
        from foxglove import messages as fm
        self.wall_clock = wall_clock
        self.fm = fm
        self.building = building
        self.georef = getattr(building, "georef", None)
        self._schemas: dict[str, tuple[str, str, bytes]] = {}

    @classmethod
    def of_context(cls, ctx: Any, *, wall_clock: bool = False) -> "FoxgloveTopics":
        """The topics of a sink's pipeline: with its building when it has one."""
        from ..contract import NoBuilding
        building = None
        if ctx.has_building:
            try:
                building = ctx.building
            except NoBuilding:
                building = None
        return cls(building, wall_clock=wall_clock)

    def _schema(self, cls: Any) -> tuple[str, str, bytes]:
        key = cls.__name__
        if key not in self._schemas:
            s = cls.get_schema()
            self._schemas[key] = (s.name, s.encoding, bytes(s.data))
        return self._schemas[key]

    def _known(self, topic: str, obj: Any, t: float) -> Record:
        name, enc, data = self._schema(type(obj))
        return Record(topic, name, enc, data, enc, obj.encode(), _ns(t))

    def _json(self, topic: str, schema: dict, data: bytes, t: float) -> Record:
        return Record(topic, schema["title"], "jsonschema", _schema_bytes(schema["title"], schema),
                      "json", data, _ns(t))

    def _stamp(self, t: float) -> Any:
        ns = _ns(t)
        return self.fm.Timestamp(sec=ns // 1_000_000_000, nsec=ns % 1_000_000_000)

    # ------------------------------------------------------------------ messages
    def records(self, stream: str, msg: Message) -> list[Record]:
        """The records of one message on input ``stream``."""
        if isinstance(msg, PoseEstimate) and msg.agent:
            return self._pose(stream, msg)
        if isinstance(msg, Diagnostic):
            return self._diagnostic(stream, msg)
        topic = f"/{stream}/{msg.agent}" if msg.agent else f"/{stream}"
        return [self._json(topic, json_schema(type(msg)), message_json(msg), msg.t)]

    def _pose(self, stream: str, msg: PoseEstimate) -> list[Record]:
        fm = self.fm
        base = f"/{stream}/{msg.agent}"
        out = [self._json(base, json_schema(PoseEstimate), message_json(msg), msg.t)]
        p = np.asarray(msg.position, float)
        if not (np.all(np.isfinite(p)) and math.isfinite(msg.heading)):
            return out
        h = float(msg.heading)
        pose = fm.Pose(position=fm.Vector3(x=float(p[0]), y=float(p[1]), z=float(p[2])),
                       orientation=fm.Quaternion(x=0.0, y=0.0, z=math.sin(h / 2),
                                                 w=math.cos(h / 2)))
        out.append(self._known(f"{base}/pose", fm.PoseInFrame(
            timestamp=self._stamp(msg.t), frame_id=msg.frame, pose=pose), msg.t))
        if self.georef is not None and msg.frame == "building":
            lon, lat, alt = self.georef.to_wgs84(p[None, :])[0]
            enu = _enu_covariance(self.georef, np.asarray(msg.cov, float))
            known = np.all(np.isfinite(enu))
            out.append(self._known(f"{base}/fix", fm.LocationFix(
                timestamp=self._stamp(msg.t), frame_id=msg.frame, latitude=float(lat),
                longitude=float(lon), altitude=float(alt),
                position_covariance=[float(v) for v in enu.ravel()] if known else [0.0] * 9,
                position_covariance_type=(fm.LocationFixPositionCovarianceType.Known if known
                                          else fm.LocationFixPositionCovarianceType.Unknown)),
                msg.t))
        return out

    def _diagnostic(self, stream: str, msg: Diagnostic) -> list[Record]:
        fm = self.fm
        level = getattr(fm.LogLevel, _LOG_LEVEL.get(msg.level, "Unknown"))
        who = f" {msg.agent}" if msg.agent else ""
        out = [self._json(f"/{stream}", json_schema(Diagnostic), message_json(msg), msg.t),
               self._known("/diagnostics", fm.Log(
                   timestamp=self._stamp(msg.t), level=level, name=msg.component,
                   message=f"[{msg.code}]{who}: {msg.text}"), msg.t)]
        if msg.code in ALARM_CODES:
            entry = {"t": msg.t if math.isfinite(msg.t) else None,
                     "when": clock_text(msg.t, date=True), "code": msg.code,
                     "agent": msg.agent, "level": msg.level, "active": msg.active,
                     "component": msg.component, "text": msg.text}
            if self.wall_clock:
                entry["wall"] = datetime.now().astimezone().isoformat(timespec="milliseconds")
            out.append(self._json("/incident_log", INCIDENT_SCHEMA,
                                  json.dumps(entry, separators=(",", ":")).encode(), msg.t))
        return out

    # ------------------------------------------------------------------ the plan
    def building_records(self, t: float) -> list[Record]:
        """``/building``: the walls, doors and openings of every floor (once, at ``t``)."""
        if self.building is None:
            return []
        fm = self.fm
        entities = []
        for f in self.building.floors:
            lines = []
            for segs, rgba, width in ((f.walls[~f.wall_is_obstacle], (0.15, 0.15, 0.15, 1.0), 0.15),
                                      ([d.jambs for d in f.doors], (0.12, 0.47, 0.71, 1.0), 0.1),
                                      ([d.jambs for d in f.openings], (0.17, 0.63, 0.17, 1.0), 0.1)):
                segs = np.asarray(segs, float).reshape(-1, 2, 2)
                if not len(segs):
                    continue
                pts = [fm.Point3(x=float(x), y=float(y), z=float(f.z))
                       for x, y in segs.reshape(-1, 2)]
                lines.append(fm.LinePrimitive(
                    type=fm.LinePrimitiveLineType.LineList, thickness=width,
                    scale_invariant=False, points=pts,
                    color=fm.Color(r=rgba[0], g=rgba[1], b=rgba[2], a=rgba[3])))
            entities.append(fm.SceneEntity(
                timestamp=self._stamp(t), frame_id="building", id=f"floor{f.index}",
                frame_locked=True, lines=lines,
                metadata=[fm.KeyValuePair(key="name", value=f.name or f"floor {f.index}"),
                          fm.KeyValuePair(key="level_m", value=f"{f.z:g}")]))
        return [self._known("/building", fm.SceneUpdate(entities=entities), t)]


def _enu_covariance(georef: Any, cov4: np.ndarray) -> np.ndarray:
    """The (3, 3) East-North-Up position covariance [m^2] of a plan (x, y, z) covariance."""
    turn = np.eye(3)
    turn[:2, :2] = true_turn(georef)
    return turn @ cov4[:3, :3] @ turn.T
