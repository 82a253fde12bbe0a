"""The ``rfid_reader`` sensor class: reads and deployments in, one detection per pass out."""
from __future__ import annotations

import math
from typing import ClassVar

from firenav_framework import Params, RawFrame, Sensor, TagDeployment, TagDetection, Tick, param
from firenav_framework.codecs import FrameError
from firenav_framework.codecs.rfid_lines import RfidEvent
from firenav_framework.codecs.selection import CodecSelection, TransportCodecs
from firenav_framework.messages import Message

from .passes import TagPass, read_problem

__all__ = ["RfidReaderSensor"]


class Frames(CodecSelection):
    """Codecs of the RawFrame inputs, per link transport."""

    record: ClassVar[type] = RfidEvent

    codecs: dict[str, str] = param({"serial": "rfid_lines", "udp": "rfid_lines"})
    """link transport -> codec decoding its lines"""


class RfidReaderSensor(Sensor):
    """RFID reader: one detection per tag pass (peak RSSI time, read count), tag deployments, reader lines."""

    name = "rfid_reader"
    inputs = (TagDetection, TagDeployment, RawFrame)
    outputs = {"detections": TagDetection, "deployments": TagDeployment}
    #: A deployed tag is on its door: reset(agent) keeps it, so every later reader
    #: (of any crew) still finds it, and the same deployment again is a duplicate.
    world_outputs = ("deployments",)

    class Params(Params):
        pass_gap: float = param(2.0, unit="s", gt=0)
        """reads of a tag closer in time than this belong to one pass; a pass ends this long after
        its last read"""
        max_pass: float = param(30.0, unit="s", gt=0)
        """a pass longer than this is reported and a new one starts (an agent standing at a tag)"""
        min_reads: int = param(1, ge=1)
        """passes with fewer reads are dropped as spurious (counted)"""
        flush_period: float = param(0.5, unit="s", gt=0)
        """how often finished passes are looked for"""
        known_tags: list[str] = param([])
        """tag ids known before the run (surveyed); reads of them are not 'unknown'"""
        readers: dict[str, str] = param({})
        """reader id -> agent, for readers not named '<agent>/<device>'"""
        frames: Frames = param(Frames())
        """RawFrame inputs: the codec per transport and its options"""

    @classmethod
    def tick_period(cls, params: Params) -> float:
        return params.flush_period

    def __init__(self, params: Params, ctx):
        super().__init__(params, ctx)
        self._passes: dict[tuple[str, str, str], TagPass] = {}
        self._deployed: dict[str, tuple[str, float]] = {}   # tag id -> (agent, t)
        self._known = set(params.known_tags)
        self._codecs = TransportCodecs(params.frames, count=ctx.count, resolve=ctx.resolve)
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
        try:
            events = self._codecs.decode(frame)
        except FrameError as exc:
            self.ctx.count("bad_lines")
            self.ctx.warn_once(frame.t, "rfid_bad_line", f"{frame.device or 'reader link'}: "
                               f"{exc} (further broken lines are only counted)",
                               agent=frame.agent)
            return
        for e in events or ():
            agent = self._agent_of(e.reader, frame.agent)
            if e.kind == "DEPLOY":
                self._deploy(e.t, agent, e.reader, e.tag_id)
            else:
                self._read(e.t, agent, e.reader, e.reader, e.tag_id, e.reads, e.rssi_dbm)

    def _agent_of(self, reader: str, agent: str) -> str:
        if reader in self.params.readers:
            return self.params.readers[reader]
        return agent or (reader.split("/", 1)[0] if "/" in reader else "")

    # -- reads and passes -------------------------------------------------------------------
    def _read(self, t: float, agent: str, device: str, reader: str, tag_id: str, reads: int,
              rssi: float | None) -> None:
        agent = agent or self._agent_of(reader, "")
        problem = read_problem(t, agent, tag_id, reads, rssi)
        if problem:
            self.ctx.count("bad_reads")
            self.ctx.log.debug("read skipped: %s", problem)
            return
        key = (agent, reader, tag_id)
        p = self._passes.get(key)
        if p is not None and t < p.last:
            self.ctx.count("out_of_order_reads", reads)
            self.ctx.warn_once(t, "rfid_out_of_order", f"{reader}: a read of {tag_id} at "
                               f"t={t:.2f} s is older than its pass's last read "
                               f"({p.last:.2f} s); such reads are skipped and counted",
                               agent=agent)
            return
        self._now = max(self._now, t)
        if p is not None and (t - p.last > self.params.pass_gap
                              or t - p.first > self.params.max_pass):
            self._emit(self._passes.pop(key))
            p = None
        if p is None:
            self._passes[key] = TagPass(agent, device or reader, reader, tag_id, t, t, reads, t, rssi)
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

    def _emit(self, p: TagPass) -> None:
        if p.reads < self.params.min_reads:
            self.ctx.count("passes_too_few_reads")
            return
        if p.tag_id not in self._deployed and p.tag_id not in self._known:
            self.ctx.count("unknown_tag_reads", p.reads)
            self.ctx.warn_once(p.first, "unknown_tag", f"{p.reader} read tag {p.tag_id}, "
                               "which was not deployed in this run and is not a known tag",
                               agent=p.agent, key=p.tag_id)
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

