"""What the page shows, handed from the pipeline to the web clients without making the
pipeline wait for them.

The pipeline thread only appends small items to an inbox (:meth:`ViewFeed.put`: a lock
held for one ``list.append``). A snapshot thread takes the inbox every ``period``
seconds, folds it into its own state and publishes an immutable :class:`Snapshot`:

* the track history as JSON text encoded once, in chunks of :data:`CHUNK` points, so a
  new client gets the bytes already made (no per-client serialising, and never one
  long encode that would hold the interpreter for the pipeline's whole budget);
* a *delta* since the previous snapshot (new points, changed firefighters, new
  diagnostics, the alarms), also encoded once and shared by every client.

Clients wait on the snapshot thread's condition, never on the pipeline's lock; a
client that fell more than :data:`DELTAS_KEPT` snapshots behind gets the full state.

Track point rows: ``[t - t0, x, y, z, floor, untrusted]`` (s, m, m, m, index or null,
0/1), ``t0`` being the first pose time of the run.

Items (:meth:`ViewFeed.put`): ``("pose", agent, t, (x, y, z, floor, untrusted))``,
``("agent", agent, <its JSON bytes>)``, ``("diag", {...})``, ``("alarms", [...])``,
``("now", t)``. Poses and agents come as tuples of numbers and bytes, which the
garbage collector does not track: the inbox holds them for up to ``period`` seconds,
and tracked objects living that long would pile up into full collections (tens of
milliseconds of a whole-process pause in a kit's interpreter).
"""
from __future__ import annotations

import json
import math
import threading
import time
from collections import deque
from dataclasses import dataclass, field
from typing import Any

__all__ = ["ViewFeed", "Snapshot", "WaitMeter", "CHUNK", "DELTAS_KEPT"]

CHUNK = 1000        # track points per pre-encoded chunk
DELTAS_KEPT = 64    # snapshots a client may lag behind and still get deltas


def _dumps(obj: Any) -> bytes:
    return json.dumps(obj, separators=(",", ":"), allow_nan=False).encode()


def _list(items: Any) -> bytes:
    """A JSON array of already encoded items."""
    return b"[" + b",".join(items) + b"]"


class WaitMeter:
    """How long the pipeline thread was held up in the sink, per message.

    Each message's time in the sink is measured as wall time (``time.perf_counter``)
    and as the CPU time this whole process used meanwhile (``time.process_time``, all
    threads): while the pipeline waits for a lock or the interpreter held by another
    thread of the kit, the process runs; while the operating system runs other
    programs, it does not. The *wait* of a message is the smaller of the two, so time
    the machine gives to other programs is not counted against the sink; it is
    counted ``over`` when it exceeds ``bound`` [s]. The largest wall time and the
    largest wait on the inbox lock (:meth:`ViewFeed.put`) are kept too. Recorded by the
    sink itself, so a load test reads a figure, not a stopwatch.
    """

    def __init__(self, bound: float):
        self.bound = bound
        self.n = 0
        self.max_s = 0.0
        self.wall_max_s = 0.0
        self.total_s = 0.0
        self.over = 0
        self.lock_max_s = 0.0

    def record(self, wall_s: float, cpu_s: float, lock_s: float = 0.0) -> None:
        wait = min(wall_s, cpu_s)
        self.n += 1
        self.total_s += wait
        self.max_s = max(self.max_s, wait)
        self.wall_max_s = max(self.wall_max_s, wall_s)
        self.lock_max_s = max(self.lock_max_s, lock_s)
        if wait > self.bound:
            self.over += 1

    def reset(self) -> None:
        """Start counting afresh (a test's measured phase)."""
        self.__init__(self.bound)

    def as_dict(self) -> dict:
        return {"messages": self.n, "max_ms": round(1e3 * self.max_s, 3),
                "mean_ms": round(1e3 * self.total_s / self.n, 4) if self.n else 0.0,
                "over_bound": self.over, "bound_ms": round(1e3 * self.bound, 3),
                "wall_max_ms": round(1e3 * self.wall_max_s, 3),
                "lock_max_ms": round(1e3 * self.lock_max_s, 3)}


@dataclass(frozen=True)
class Snapshot:
    """One published state. ``head``: the JSON members (without braces) of everything
    but the tracks; ``tracks``: per agent the encoded chunks (comma-joined rows);
    ``delta``: the JSON of the changes since snapshot ``seq - 1``."""

    seq: int
    head: bytes
    tracks: dict[str, tuple[bytes, ...]]
    delta: bytes

    def full_parts(self, extra: bytes = b"") -> list[bytes]:
        """The full state as byte pieces (write them in order; no join of megabytes);
        ``extra``: more JSON members, each followed by a comma."""
        parts = [b'{"type":"full",' + extra, self.head, b',"tracks":{']
        for i, (agent, chunks) in enumerate(self.tracks.items()):
            parts.append((b"," if i else b"") + _dumps(agent) + b":[")
            for j, chunk in enumerate(chunks):
                if j:
                    parts.append(b",")
                parts.append(chunk)
            parts.append(b"]")
        parts.append(b"}}")
        return parts


@dataclass
class _Track:
    """One firefighter's history: sealed chunks and the open chunk, all encoded."""

    sealed: list[bytes] = field(default_factory=list)
    tail: bytearray = field(default_factory=bytearray)
    tail_rows: int = 0
    dropped: int = 0


class ViewFeed:
    """The inbox (pipeline side) and the snapshot thread (client side)."""

    def __init__(self, *, period: float = 0.25, max_points: int = 20000,
                 max_diagnostics: int = 500):
        self.period = period
        self.max_points = max_points
        self._inbox: list[tuple] = []
        self._inbox_lock = threading.Lock()
        self._publish_lock = threading.Lock()
        self.cond = threading.Condition()   # clients wait here (never the pipeline)
        self._closing = threading.Event()
        self._deltas: deque[tuple[int, bytes]] = deque(maxlen=DELTAS_KEPT)
        self.snapshot = Snapshot(0, b'"seq":0,"now":null,"t0":null,"agents":[],'
                                    b'"alarms":[],"diagnostics":[]', {}, b"")
        # state of the snapshot thread only, each piece encoded once
        self._agents: dict[str, bytes] = {}
        self._alarms: bytes = b"[]"
        self._diags: deque[bytes] = deque(maxlen=max_diagnostics)
        self._diag_seq = 0
        self._tracks: dict[str, _Track] = {}
        self._now: float | None = None
        self.t0: float | None = None
        self._thread = threading.Thread(target=self._run, name="live-view-snapshots",
                                        daemon=True)

    # ------------------------------------------------------------- pipeline side
    def put(self, item: tuple) -> float:
        """Hand one item to the snapshot thread; returns the time [s] spent waiting for
        the lock (0 when it was free)."""
        if self._inbox_lock.acquire(blocking=False):
            waited = 0.0
        else:
            t0 = time.perf_counter()
            self._inbox_lock.acquire()
            waited = time.perf_counter() - t0
        try:
            self._inbox.append(item)
        finally:
            self._inbox_lock.release()
        return waited

    # ------------------------------------------------------------- snapshot thread
    def start(self) -> None:
        self._thread.start()

    def close(self) -> None:
        self._closing.set()
        self._thread.join(5.0)
        with self.cond:
            self.cond.notify_all()

    @property
    def closing(self) -> bool:
        return self._closing.is_set()

    def _run(self) -> None:
        while not self._closing.is_set():
            self._closing.wait(self.period)
            self.publish()

    def publish(self) -> None:
        """Fold the inbox into a new snapshot (the snapshot thread; also at the end, and
        tests call it). One publisher at a time; the pipeline never waits for it."""
        with self._publish_lock:
            self._publish()

    def _publish(self) -> None:
        with self._inbox_lock:
            items, self._inbox = self._inbox, []
        if not items:
            return
        new_points: dict[str, list[list]] = {}
        changed: dict[str, bytes] = {}
        new_diags: list[bytes] = []
        alarms_changed = False
        for item in items:
            kind = item[0]
            if kind == "pose":
                _, agent, t, xyz_floor_untrusted = item
                if self.t0 is None:
                    self.t0 = t
                row = [round(t - self.t0, 3), *xyz_floor_untrusted]
                self._add_point(agent, row)
                new_points.setdefault(agent, []).append(row)
            elif kind == "agent":
                self._agents[item[1]] = changed[item[1]] = item[2]
            elif kind == "diag":
                self._diag_seq += 1
                d = _dumps({"seq": self._diag_seq, **item[1]})
                self._diags.append(d)
                new_diags.append(d)
            elif kind == "alarms":
                self._alarms, alarms_changed = _dumps(item[1]), True
            elif kind == "now":
                self._now = item[1]
        seq = self.snapshot.seq + 1
        clock = (b'"seq":' + _dumps(seq) + b',"now":' + _dumps(self._now) + b',"t0":'
                 + _dumps(self.t0))
        head = (clock + b',"agents":' + _list(self._agents[a] for a in sorted(self._agents))
                + b',"alarms":' + self._alarms + b',"diagnostics":' + _list(self._diags))
        delta = (b'{"type":"delta",' + clock + b',"agents":'
                 + _list(changed[a] for a in sorted(changed))
                 + b',"alarms":' + (self._alarms if alarms_changed else b"null")
                 + b',"diagnostics":' + _list(new_diags)
                 + b',"tracks":' + _dumps(new_points) + b"}")
        tracks = {a: tuple(tr.sealed) + ((bytes(tr.tail),) if tr.tail_rows else ())
                  for a, tr in sorted(self._tracks.items())}
        snap = Snapshot(seq, head, tracks, delta)
        with self.cond:
            self.snapshot = snap
            self._deltas.append((seq, snap.delta))
            self.cond.notify_all()

    def _add_point(self, agent: str, row: list) -> None:
        tr = self._tracks.setdefault(agent, _Track())
        if tr.tail_rows:
            tr.tail += b","
        tr.tail += _dumps(row)
        tr.tail_rows += 1
        if tr.tail_rows >= CHUNK:
            tr.sealed.append(bytes(tr.tail))
            tr.tail, tr.tail_rows = bytearray(), 0
            while len(tr.sealed) * CHUNK > self.max_points:
                tr.sealed.pop(0)
                tr.dropped += CHUNK

    # ------------------------------------------------------------- client side
    def wait_after(self, seq: int, timeout: float) -> Snapshot:
        """The newest snapshot once it is newer than ``seq`` (or after ``timeout`` [s])."""
        with self.cond:
            self.cond.wait_for(lambda: self.snapshot.seq != seq or self._closing.is_set(),
                               timeout=timeout)
            return self.snapshot

    def deltas_after(self, seq: int, snap: Snapshot) -> list[bytes] | None:
        """The deltas taking a client from ``seq`` to ``snap.seq``, or None when it fell
        too far behind (it then needs the full state)."""
        with self.cond:
            kept = [d for s, d in self._deltas if seq < s <= snap.seq]
        return kept if len(kept) == snap.seq - seq else None


def finite(v: float) -> float | None:
    """A float for JSON (None when not finite), rounded to the mm / mrad the page uses."""
    return round(float(v), 3) if math.isfinite(v) else None
