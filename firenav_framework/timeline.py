"""Merges message streams into one measurement-time order, with named rules.

Messages enter with :meth:`Timeline.push` and leave, sorted by time, through
:meth:`Timeline.release`. A message is held until the newest time seen is at least
``reorder_window`` seconds past it, so late arrivals within the window are put back in
order. The rules below are applied per *channel*: one stream of one device.

``duplicate``
    A message identical in content and time to one of the last ``duplicate_memory``
    messages of its channel is dropped (``duplicates: drop``) or passed on (``keep``).
``late``
    A message older than one already released cannot be put in order any more. It is
    dropped (``late: drop``) or delivered at once, out of order (``late: deliver``).
``clock_jump``
    A channel whose time steps back by more than ``clock_jump`` seconds (and more than
    the reorder window, within which a step back is just a late arrival), or (when
    receive times are known) whose measurement-time step disagrees with its
    receive-time step by more than that, has had its clock reset. With
    ``on_clock_jump: rebase`` the channel's later times are shifted so that it
    continues where it was (one typical sample interval on); with ``drop`` its
    messages are dropped until its time passes the old time again.
``gap``
    A forward step longer than ``gap`` seconds (without a clock jump) in a channel of
    periodic data (IMU blocks, raw frames, ground truth: ``Message.periodic``) is a
    gap: the data are kept and a ``gap`` diagnostic is issued. Event streams (tag
    reads, drops) are silent most of the time and are not checked.
``max_lead`` (the bound on time)
    A message more than ``max_lead`` seconds ahead of the newest time on the timeline
    (a corrupt timestamp: a flipped byte in a log, ``t: 1e308``) is held, not used. Its
    channel's next messages decide: ``lead_confirm`` of them in a row near it confirm a
    real leap (a recording paused for hours): they are used, and the ticks of the
    empty span are skipped (counted ``ticks_skipped``); a message back near the
    newest time shows it was corrupt: the held ones are dropped (counted
    ``implausible_time``, reported once per device). What is still held at the end is
    dropped too. The first message of a run sets the reference. So one bad value can
    never make the timeline emit ticks or hold messages without bound.

Periodic ticks: every registered period produces :class:`Tick` messages at
multiples of the period, released before any message with a later time; between two
data times more than ``max_lead`` apart no ticks are emitted. The output is
deterministic: equal input always gives equal output order.
"""
from __future__ import annotations

import heapq
import math
from collections import deque
from dataclasses import dataclass, field
from typing import Literal

from pydantic import ConfigDict, Field

from .field_docs import DescribedModel

from .messages import Diagnostic, Message, Tick
from .stats import RunStats

TIMELINE_ID = "timeline"


class TimelineConfig(DescribedModel):
    """The timeline's rules (the ``timeline:`` section of a pipeline)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    reorder_window: float = Field(0.25, ge=0, json_schema_extra={"unit": "s"})
    """hold messages this long [s] to reorder late arrivals"""
    duplicates: Literal["drop", "keep"] = Field("drop")
    """rule for exact duplicates"""
    duplicate_memory: int = Field(64, ge=1, le=100_000)
    """messages per channel remembered for duplicate detection"""
    late: Literal["drop", "deliver"] = Field("drop")
    """rule for messages older than ones already released"""
    clock_jump: float = Field(5.0, gt=0, json_schema_extra={"unit": "s"})
    """a time step back larger than this [s] is a clock jump"""
    on_clock_jump: Literal["rebase", "drop"] = Field("rebase")
    """rule for clock jumps"""
    gap: float = Field(2.0, gt=0, json_schema_extra={"unit": "s"})
    """a silence longer than this [s] is reported as a gap"""
    max_lead: float = Field(3600.0, gt=0, le=1e7, json_schema_extra={"unit": "s"})
    """a message more than this [s] ahead of the newest time is held until its channel confirms the
    leap"""
    lead_confirm: int = Field(3, ge=1, le=100)
    """messages in a row near a held one that confirm a real leap of time"""


@dataclass
class _Channel:
    last_t: float = -math.inf
    last_recv: float | None = None
    offset: float = 0.0
    typical_dt: float = 0.0
    dropping_until: float | None = None
    recent: deque = field(default_factory=deque)   # the last messages, for duplicates
    recent_t_max: float = -math.inf                # the newest time among them
    held: list = field(default_factory=list)  # (stream, msg, t_recv) ahead by > max_lead
    implausible: int = 0


@dataclass(order=True)
class _Entry:
    t: float
    seq: int
    stream: str = field(compare=False)
    msg: Message = field(compare=False)


class Timeline:
    """See the module docstring for the rules."""

    def __init__(self, config: TimelineConfig | None = None, stats: RunStats | None = None):
        self.config = config or TimelineConfig()
        self.stats = stats or RunStats()
        self._heap: list[_Entry] = []
        self._seq = 0
        self._channels: dict[tuple[str, str], _Channel] = {}
        self._newest = -math.inf
        self._released = -math.inf
        self._ticks: list[list] = []  # [index of next tick or None, period, stream]
        self._out: list[tuple[str, Message]] = []  # late deliveries and diagnostics
        self._holding: set[tuple[str, str]] = set()  # channels with held messages
        self._pool: list[tuple] | None = []  # the first messages, until they set the reference

    # -- configuration ------------------------------------------------------------
    def add_tick(self, period: float, stream: str) -> None:
        """Emit ``Tick`` messages every ``period`` seconds on ``stream``."""
        if not period > 0:
            raise ValueError(f"tick period must be positive, got {period}")
        self._ticks.append([None, period, stream])

    # -- input --------------------------------------------------------------------
    def push(self, stream: str, msg: Message, t_recv: float | None = None) -> None:
        """Accept one message from ``stream``; it may be held, dropped or passed on."""
        cfg = self.config
        key = (stream, msg.device or msg.agent)
        ch = self._channels.get(key)
        if ch is None:
            ch = self._channels[key] = _Channel(recent=deque(maxlen=cfg.duplicate_memory))
        if t_recv is None:
            t_recv = getattr(msg, "t_recv", None)
        if not math.isfinite(msg.t):
            self._count("bad_time")
            return

        if ch.offset:
            msg = msg.shifted(ch.offset)
        if cfg.duplicates == "drop":
            if msg.t <= ch.recent_t_max and self._is_duplicate(ch, msg):
                self._count("duplicates")
                return
            ch.recent.append(msg)
            ch.recent_t_max = max(ch.recent_t_max, msg.t)

        if ch.dropping_until is not None:
            if msg.t <= ch.dropping_until:
                self._count("clock_jump_dropped")
                return
            ch.dropping_until = None
        self._accept(stream, key, ch, msg, t_recv)

    def _accept(self, stream: str, key: tuple[str, str], ch: _Channel, msg: Message,
                t_recv: float | None, confirmed: bool = False) -> None:
        """The clock-jump, lead, gap and late rules, then into the reorder heap."""
        cfg = self.config
        dt = 0.0
        if ch.last_t > -math.inf:
            dt = msg.t - ch.last_t
            jump = None
            if t_recv is not None and ch.last_recv is not None:
                if abs(dt - (t_recv - ch.last_recv)) > cfg.clock_jump:
                    jump = dt - (t_recv - ch.last_recv)
            elif dt < -max(cfg.clock_jump, cfg.reorder_window):
                jump = dt - ch.typical_dt
            if jump is not None:
                msg = self._clock_jump(stream, key, ch, msg, jump)
                if msg is None:
                    return
                dt = msg.t - ch.last_t
        if not confirmed:
            if self._pool is not None:
                self._pool.append((stream, key, ch, msg, t_recv))
                if len(self._pool) >= cfg.lead_confirm:
                    self._start()
                return
            if msg.t > self._newest + cfg.max_lead:
                self._hold(stream, key, ch, msg, t_recv)
                return
            if ch.held:
                self._drop_held(key, ch)
        if ch.last_t > -math.inf:
            if dt > cfg.gap and msg.periodic:
                self._count("gaps")
                self._diagnose(msg, "gap", f"{stream}: no data for {dt:.2f} s "
                               f"(device {key[1] or '?'})")
            if 0 < dt <= cfg.gap:
                ch.typical_dt = dt
        if t_recv is not None:
            ch.last_recv = t_recv
        ch.last_t = max(ch.last_t, msg.t)

        if msg.t < self._released:
            if cfg.late == "drop":
                self._count("late_dropped")
                return
            self._count("late_delivered")
            self._out.append((stream, msg))
            return
        if msg.t > self._newest:
            self._newest = msg.t
            if self._holding:
                self._recheck_held()
        heapq.heappush(self._heap, _Entry(msg.t, self._seq, stream, msg))
        self._seq += 1

    @staticmethod
    def _is_duplicate(ch: _Channel, msg: Message) -> bool:
        """Whether one of the channel's remembered messages equals ``msg`` exactly.

        Only called for a message no newer than the newest remembered one: a duplicate
        has the time of the one it repeats, so a channel whose times go forward (every
        live link, every steady stream) never computes a key at all.
        """
        same_time = [m for m in ch.recent if m.t == msg.t]
        if not same_time:
            return False
        key = msg.dedup_key()
        return any(m.dedup_key() == key for m in same_time)
    # -- the lead rule ---------------------------------------------------------------
    def _start(self) -> None:
        """Set the reference time from the first messages: their median, so that one
        corrupt first stamp cannot become it. Messages far behind it are dropped, those
        far ahead are held like any other."""
        pool, self._pool = self._pool or [], None
        if not pool:
            return
        times = sorted(entry[3].t for entry in pool)
        self._newest = times[len(times) // 2]
        for stream, key, ch, msg, t_recv in pool:
            if msg.t < self._newest - self.config.max_lead:
                ch.held = [(stream, msg, t_recv)]
                self._drop_held(key, ch)
            else:
                self._accept(stream, key, ch, msg, t_recv)

    def _hold(self, stream: str, key: tuple[str, str], ch: _Channel, msg: Message,
              t_recv: float | None) -> None:
        """Keep a message far ahead of the newest time until its channel decides."""
        if ch.held and abs(msg.t - ch.held[0][1].t) > self.config.max_lead:
            self._drop_held(key, ch)  # not near the held ones either: they were corrupt
        ch.held.append((stream, msg, t_recv))
        self._holding.add(key)
        if len(ch.held) >= self.config.lead_confirm:
            self._confirm_held(key, ch)

    def _confirm_held(self, key: tuple[str, str], ch: _Channel) -> None:
        held, ch.held = ch.held, []
        self._holding.discard(key)
        first = held[0][1]
        self._count("time_leaps")
        self._diagnose(first, "time_leap", f"{held[0][0]}: device {key[1] or '?'} "
                       f"continues {first.t - self._newest:.3g} s after the newest data "
                       f"(confirmed by {len(held)} messages); its data are used")
        for stream, msg, t_recv in held:
            self._accept(stream, key, ch, msg, t_recv, confirmed=True)

    def _drop_held(self, key: tuple[str, str], ch: _Channel) -> None:
        n, first = len(ch.held), ch.held[0]
        ch.held = []
        self._holding.discard(key)
        self.stats.count(TIMELINE_ID, "implausible_time", n)
        if ch.implausible == 0:
            self._diagnose(first[1], "implausible_time", f"{first[0]}: device "
                           f"{key[1] or '?'} sent t={first[1].t:.6g} s, more than "
                           f"{self.config.max_lead:g} s (max_lead) ahead of the newest "
                           f"data and not continued: dropped", t=self._now())
        ch.implausible += n

    def _recheck_held(self) -> None:
        """Held messages that the newest time has come within reach of are used."""
        for key in sorted(self._holding):
            ch = self._channels[key]
            if ch.held and ch.held[0][1].t <= self._newest + self.config.max_lead:
                held, ch.held = ch.held, []
                self._holding.discard(key)
                for stream, msg, t_recv in held:
                    self._accept(stream, key, ch, msg, t_recv, confirmed=True)

    def _clock_jump(self, stream: str, key: tuple[str, str], ch: _Channel,
                    msg: Message, jump: float) -> Message | None:
        self._count("clock_jumps")
        if self.config.on_clock_jump == "drop":
            self._diagnose(msg, "clock_jump", f"{stream}: device {key[1] or '?'} clock "
                           f"jumped {jump:+.3f} s; dropping its data until it catches up")
            ch.dropping_until = ch.last_t
            return None
        ch.offset -= jump
        self._diagnose(msg, "clock_jump", f"{stream}: device {key[1] or '?'} clock "
                       f"jumped {jump:+.3f} s; later times shifted by {-jump:+.3f} s")
        return msg.shifted(-jump)

    # -- output -------------------------------------------------------------------
    def release(self, *, flush: bool = False, older_than: float | None = None
                ) -> list[tuple[str, Message]]:
        """Messages (with interleaved ticks) whose order can no longer change.

        ``flush`` releases everything (end of input). ``older_than`` also releases
        messages with time at or before it (used by live runs to bound latency).
        """
        if flush:
            self._start()
            for key in sorted(self._holding):
                self._drop_held(key, self._channels[key])
        out, self._out = self._out, []
        limit = math.inf if flush else self._newest - self.config.reorder_window
        if older_than is not None:
            limit = max(limit, older_than)
        while self._heap and self._heap[0].t <= limit:
            entry = heapq.heappop(self._heap)
            self._emit_ticks(entry.t, out)
            self._released = max(self._released, entry.t)
            out.append((entry.stream, entry.msg))
        return out

    def _emit_ticks(self, t: float, out: list[tuple[str, Message]]) -> None:
        if not self._ticks:
            return
        for tick in self._ticks:
            if tick[0] is None:  # the first tick is the first multiple at or after t
                tick[0] = _tick_index(t, tick[1])
            elif t - tick[0] * tick[1] > self.config.max_lead:  # a confirmed leap
                skip = _tick_index(t, tick[1])
                self.stats.count(TIMELINE_ID, "ticks_skipped",
                                 int(min(skip - tick[0], 2**62)))
                tick[0] = skip
        while True:  # tick k is at k * period exactly, so no rounding drift builds up
            nxt = min(self._ticks, key=lambda k: (k[0] * k[1], k[2]))
            t_tick = nxt[0] * nxt[1]
            if t_tick > t:
                return
            out.append((nxt[2], Tick(t=t_tick, period=nxt[1])))
            nxt[0] += 1

    def _now(self) -> float:
        """A time for the timeline's own reports that keeps its output in order."""
        if self._released > -math.inf:
            return self._released
        return self._heap[0].t if self._heap else max(self._newest, 0.0)

    @property
    def pending(self) -> int:
        return len(self._heap)

    def _count(self, what: str) -> None:
        self.stats.count(TIMELINE_ID, what)

    def _diagnose(self, msg: Message, code: str, text: str, t: float | None = None) -> None:
        self._out.append((f"{TIMELINE_ID}.diagnostics", Diagnostic(
            t=msg.t if t is None else t, agent=msg.agent, component=TIMELINE_ID, level="warning",
            code=code, text=text)))


def _tick_index(t: float, period: float) -> float:
    """Index of the first tick at or after ``t``; inf (no more ticks) beyond float range."""
    k = t / period - 1e-9
    return float(math.ceil(k)) if math.isfinite(k) else math.inf
