"""RFID reader worn by a firefighter: tag reads debounced into one detection per pass.

The RFID/MEMS paper (rfid-mems-ekf, "RFID and Database") has the first team stick a tag
on each door jamb (and at both ends of each stair) and every agent's reader correct the
position when it passes a tag. A reader reports a tag many times while it is in range
(several read attempts a second), so this sensor merges the reads of one tag by one
reader into a **pass**: reads closer than ``pass_gap`` seconds belong together, and a
pass ends ``pass_gap`` after its last read (or after ``max_pass`` seconds, for an agent
standing at a tag). A pass becomes one :class:`TagDetection` whose time is that of the
**strongest read** (the reader is nearest the tag then), with the total read count and
that peak RSSI. The sensor needs time to pass to close a pass: it ticks every
``flush_period`` seconds.

Inputs: ``TagDetection`` (raw or window-aggregated reads, e.g. the simulator's),
``TagDeployment`` (the dispenser's "tag attached" events) and ``RawFrame`` text lines
from a serial or UDP link (one line per read or deployment; ``*HH`` optional, the XOR of
the bytes before ``*`` in hex, as NMEA)::

    TAG,<reader>,<tag_id>,<rssi_dbm>[,<reads>]     a read; rssi may be empty
    DEPLOY,<reader>,<tag_id>                       the wearer attached this tag

``reader`` is the device id ``<agent>/<device>`` (``ff1/rfid``) unless ``readers`` maps
it to an agent. Other lines on the link are counted and skipped; broken ones are
counted and reported once.

Bad data is never fatal: a read of a tag no one deployed (and not in ``known_tags``) is
passed on, counted (``unknown_tag_reads``) and reported once per tag; a second
deployment of an id already deployed is a **duplicate tag id**: counted, reported, and
dropped (the first placement stands).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from firenav_framework import Params, RawFrame, Sensor, TagDeployment, TagDetection, Tick, param
from firenav_framework.messages import Message

from .checked_lines import NAME, LineProblem, decode_fields, encode_fields

__all__ = ["RfidLine", "decode_rfid_line", "encode_rfid_line", "RfidReaderSensor", "PLUGINS"]



class LineError(ValueError):
    """A reader line that is ours but broken."""


@dataclass(frozen=True)
class RfidLine:
    """One decoded reader line: ``kind`` "TAG" or "DEPLOY"."""

    kind: str
    reader: str
    tag_id: str
    rssi_dbm: float | None = None
    reads: int = 1


def encode_rfid_line(line: RfidLine, checksum: bool = True) -> bytes:
    """The text of a reader line (no terminator), with its ``*HH`` checksum."""
    fields = [line.kind, line.reader, line.tag_id]
    if line.kind == "TAG":
        fields.append("" if line.rssi_dbm is None else f"{line.rssi_dbm:.1f}")
        if line.reads != 1:
            fields.append(str(line.reads))
    return encode_fields(fields, checksum)


def decode_rfid_line(data: bytes) -> RfidLine | None:
    """Decode one line; None if it is not a reader line; LineError if it is broken."""
    try:
        parts = decode_fields(data, ("TAG", "DEPLOY"))
    except LineProblem as e:
        raise LineError(str(e)) from None
    if parts is None:
        return None
    text = ",".join(parts)
    kind = parts[0]
    if kind == "DEPLOY" and len(parts) != 3 or kind == "TAG" and len(parts) not in (4, 5):
        raise LineError(f"{kind} line has {len(parts)} fields: {text!r}")
    reader, tag_id = parts[1], parts[2]
    if not (NAME.match(reader) and NAME.match(tag_id)):
        raise LineError(f"bad reader or tag id: {text!r}")
    if kind == "DEPLOY":
        return RfidLine("DEPLOY", reader, tag_id)
    try:
        rssi = float(parts[3]) if parts[3] else None
        reads = int(parts[4]) if len(parts) == 5 else 1
    except ValueError:
        raise LineError(f"non-numeric field: {text!r}") from None
    if (rssi is not None and not math.isfinite(rssi)) or reads < 1:
        raise LineError(f"field out of range: {text!r}")
    return RfidLine("TAG", reader, tag_id, rssi, reads)


@dataclass
class _Pass:
    """The reads of one tag by one reader so far."""

    agent: str
    device: str
    reader: str
    tag_id: str
    first: float
    last: float
    reads: int
    peak_t: float
    peak_rssi: float | None

    def add(self, t: float, reads: int, rssi: float | None) -> None:
        self.last = max(self.last, t)
        self.reads += reads
        if rssi is not None and (self.peak_rssi is None or rssi > self.peak_rssi):
            self.peak_rssi, self.peak_t = rssi, t

    def detection(self) -> TagDetection:
        t = self.peak_t if self.peak_rssi is not None else 0.5 * (self.first + self.last)
        return TagDetection(t=t, agent=self.agent, device=self.device, tag_id=self.tag_id,
                            reader=self.reader, rssi_dbm=self.peak_rssi, reads=self.reads)


class RfidReaderSensor(Sensor):
    """RFID reader: one detection per tag pass (peak RSSI time, read count), tag deployments, reader lines."""

    name = "rfid_reader"
    inputs = (TagDetection, TagDeployment, RawFrame)
    outputs = {"detections": TagDetection, "deployments": TagDeployment}

    class Params(Params):
        pass_gap: float = param(2.0, unit="s", gt=0, description="reads of a tag closer in "
                                "time than this belong to one pass; a pass ends this long "
                                "after its last read")
        max_pass: float = param(30.0, unit="s", gt=0, description="a pass longer than this is "
                                "reported and a new one starts (an agent standing at a tag)")
        min_reads: int = param(1, ge=1, description="passes with fewer reads are dropped as "
                               "spurious (counted)")
        flush_period: float = param(0.5, unit="s", gt=0, description="how often finished "
                                    "passes are looked for")
        known_tags: list[str] = param([], description="tag ids known before the run "
                                      "(surveyed); reads of them are not 'unknown'")
        readers: dict[str, str] = param({}, description="reader id -> agent, for readers "
                                        "not named '<agent>/<device>'")

    @classmethod
    def tick_period(cls, params: Params) -> float:
        return params.flush_period

    def __init__(self, params: Params, ctx):
        super().__init__(params, ctx)
        self._passes: dict[tuple[str, str, str], _Pass] = {}
        self._deployed: dict[str, tuple[str, float]] = {}   # tag id -> (agent, t)
        self._known = set(params.known_tags)
        self._reported: set[str] = set()
        self._now = -math.inf

    def reset(self, agent: str) -> None:
        for key in [k for k in self._passes if k[0] == agent]:
            del self._passes[key]

    # -- input ---------------------------------------------------------------------------
    def handle(self, stream: str, msg: Message) -> None:
        if isinstance(msg, Tick):
            self._flush(msg.t)
        elif isinstance(msg, TagDetection):
            self._read(msg.t, msg.agent, msg.device, msg.reader or msg.device, msg.tag_id,
                       msg.reads, msg.rssi_dbm)
        elif isinstance(msg, TagDeployment):
            self._deploy(msg.t, msg.agent, msg.device, msg.tag_id)
        elif isinstance(msg, RawFrame):
            self._raw(msg)
        else:
            self.ctx.count("ignored_messages")

    def finish(self) -> None:
        self._flush(math.inf)

    def _raw(self, frame: RawFrame) -> None:
        if frame.transport not in ("serial", "udp"):
            self.ctx.count("frames_not_lines")
            return
        try:
            line = decode_rfid_line(frame.data)
        except LineError as exc:
            self.ctx.count("bad_lines")
            if "bad_lines" not in self._reported:
                self._reported.add("bad_lines")
                self.ctx.diagnose(frame.t, "warning", "rfid_bad_line",
                                  f"{frame.device or 'reader link'}: {exc} (further broken "
                                  "lines are only counted)", agent=frame.agent)
            return
        if line is None:
            self.ctx.count("other_lines")
            return
        agent = self._agent_of(line.reader, frame.agent)
        if line.kind == "DEPLOY":
            self._deploy(frame.t, agent, line.reader, line.tag_id)
        else:
            self._read(frame.t, agent, line.reader, line.reader, line.tag_id, line.reads,
                       line.rssi_dbm)

    def _agent_of(self, reader: str, agent: str) -> str:
        if reader in self.params.readers:
            return self.params.readers[reader]
        return agent or (reader.split("/", 1)[0] if "/" in reader else "")

    # -- reads and passes -------------------------------------------------------------------
    def _read(self, t: float, agent: str, device: str, reader: str, tag_id: str, reads: int,
              rssi: float | None) -> None:
        agent = agent or self._agent_of(reader, "")
        problem = _read_problem(t, agent, tag_id, reads, rssi)
        if problem:
            self.ctx.count("bad_reads")
            self.ctx.log.debug("read skipped: %s", problem)
            return
        self._now = max(self._now, t)
        key = (agent, reader, tag_id)
        p = self._passes.get(key)
        if p is not None and (t - p.last > self.params.pass_gap
                              or t - p.first > self.params.max_pass):
            self._emit(self._passes.pop(key))
            p = None
        if p is None:
            self._passes[key] = _Pass(agent, device or reader, reader, tag_id, t, t, reads, t, rssi)
        else:
            p.add(t, reads, rssi)
        self.ctx.count("reads", reads)
        self._flush(self._now)

    def _flush(self, now: float) -> None:
        """Close and emit the passes whose last read is older than ``pass_gap`` at time
        ``now`` [s] (infinity: all of them)."""
        done = [k for k, p in self._passes.items() if now - p.last > self.params.pass_gap]
        for p in sorted((self._passes.pop(k) for k in done), key=lambda p: p.peak_t):
            self._emit(p)

    def _emit(self, p: _Pass) -> None:
        if p.reads < self.params.min_reads:
            self.ctx.count("passes_too_few_reads")
            return
        if p.tag_id not in self._deployed and p.tag_id not in self._known:
            self.ctx.count("unknown_tag_reads", p.reads)
            if p.tag_id not in self._reported:
                self._reported.add(p.tag_id)
                self.ctx.diagnose(p.first, "warning", "unknown_tag",
                                  f"{p.reader} read tag {p.tag_id}, which was not deployed in "
                                  "this run and is not a known tag", agent=p.agent)
        self.ctx.count("detections")
        self.ctx.publish("detections", p.detection())

    # -- deployments ----------------------------------------------------------------------
    def _deploy(self, t: float, agent: str, device: str, tag_id: str) -> None:
        if not agent or not tag_id or not math.isfinite(t):
            self.ctx.count("bad_deployments")
            return
        first = self._deployed.get(tag_id)
        if first is not None:
            self.ctx.count("duplicate_tag_deployments")
            self.ctx.diagnose(t, "warning", "duplicate_tag_id",
                              f"tag id {tag_id} deployed again by {agent} (first by {first[0]} "
                              f"at t={first[1]:.1f} s): the second placement is ignored",
                              agent=agent)
            return
        self._deployed[tag_id] = (agent, t)
        self.ctx.count("deployments")
        self.ctx.publish("deployments", TagDeployment(t=t, agent=agent, device=device,
                                                      tag_id=tag_id))


def _read_problem(t: float, agent: str, tag_id: str, reads: int, rssi: float | None) -> str:
    if not math.isfinite(t):
        return "non-finite time"
    if not agent:
        return "no agent for the reader"
    if not tag_id:
        return "empty tag id"
    if not isinstance(reads, int) or reads < 1:
        return f"read count {reads!r}"
    if rssi is not None and not math.isfinite(rssi):
        return "non-finite RSSI"
    return ""


PLUGINS = [RfidReaderSensor]
