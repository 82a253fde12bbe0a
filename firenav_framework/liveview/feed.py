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


class WaitMeter:
    """How long the pipeline thread spent in the sink per message (wall clock,
    ``time.perf_counter``): the count, the largest and how many exceeded ``bound`` [s].
    Recorded by the sink itself so a load test reads a figure, not a stopwatch."""

    def __init__(self, bound: float):
        self.bound = bound
        self.n = 0
        self.max_s = 0.0
        self.total_s = 0.0
        self.over = 0
        self.lock_max_s = 0.0

    def record(self, seconds: float, lock_s: float = 0.0) -> None:
        self.n += 1
        self.total_s += seconds
        if seconds > self.max_s:
            self.max_s = seconds
        if seconds > self.bound:
            self.over += 1
        if lock_s > self.lock_max_s:
            self.lock_max_s = lock_s

    def as_dict(self) -> dict:
        return {"messages": self.n, "max_ms": round(1e3 * self.max_s, 3),
                "mean_ms": round(1e3 * self.total_s / self.n, 4) if self.n else 0.0,
                "over_bound": self.over, "bound_ms": round(1e3 * self.bound, 3),
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
                parts.append(b"," + chunk if j else chunk)
            parts.append(b"]")
        parts.append(b"}}")
        return parts


@dataclass
class _Track:
    sealed: list[bytes] = field(default_factory=list)
    tail: list[list] = field(default_factory=list)
    dropped: int = 0


class ViewFeed:
    """The inbox (pipeline side) and the snapshot thread (client side)."""

    def __init__(self, *, period: float = 0.25, max_points: int = 20000,
                 max_diagnostics: int = 500):
        self.period = period
        self.max_points = max_points
        self._inbox: list[tuple] = []
        self._inbox_lock = threading.Lock()
        self._wake = threading.Event()
        self.cond = threading.Condition()   # clients wait here (never the pipeline)
        self._closing = threading.Event()
        self._deltas: deque[tuple[int, bytes]] = deque(maxlen=DELTAS_KEPT)
        self.snapshot = Snapshot(0, b'"seq":0,"now":null,"t0":null,"agents":[],'
                                    b'"alarms":[],"diagnostics":[]', {}, b"")
        # state of the snapshot thread only
        self._agents: dict[str, dict] = {}
        self._alarms: list[dict] = []
        self._diags: deque[dict] = deque(maxlen=max_diagnostics)
        self._diag_seq = 0
        self._tracks: dict[str, _Track] = {}
        self._now: float | None = None
        self.t0: float | None = None
        self._thread = threading.Thread(target=self._run, name="live-view-snapshots",
                                        daemon=True)

    # ------------------------------------------------------------- pipeline side
    def put(self, item: tuple) -> float:
        """Hand one item to the snapshot thread; returns the lock wait [s]."""
        t0 = time.perf_counter()
        with self._inbox_lock:
            waited = time.perf_counter() - t0
            self._inbox.append(item)
        return waited

    # ------------------------------------------------------------- snapshot thread
    def start(self) -> None:
        self._thread.start()

    def close(self) -> None:
        self._closing.set()
        self._wake.set()
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
        """Fold the inbox into a new snapshot (the snapshot thread; tests call it)."""
        with self._inbox_lock:
            items, self._inbox = self._inbox, []
        if not items:
            return
        new_points: dict[str, list[list]] = {}
        changed: dict[str, dict] = {}
        new_diags: list[dict] = []
        alarms_changed = False
        for item in items:
            kind = item[0]
            if kind == "pose":
                _, agent, t, row = item
                if self.t0 is None:
                    self.t0 = t
                row[0] = round(t - self.t0, 3)
                self._add_point(agent, row)
                new_points.setdefault(agent, []).append(row)
            elif kind == "agent":
                self._agents[item[1]] = changed[item[1]] = item[2]
            elif kind == "diag":
                self._diag_seq += 1
                d = {"seq": self._diag_seq, **item[1]}
                self._diags.append(d)
                new_diags.append(d)
            elif kind == "alarms":
                self._alarms, alarms_changed = item[1], True
            elif kind == "now":
                self._now = item[1]
        seq = self.snapshot.seq + 1
        head = {"seq": seq, "now": self._now, "t0": self.t0,
                "agents": [self._agents[a] for a in sorted(self._agents)],
                "alarms": self._alarms, "diagnostics": list(self._diags)}
        delta = {"type": "delta", "seq": seq, "now": self._now, "t0": self.t0,
                 "agents": [changed[a] for a in sorted(changed)],
                 "alarms": self._alarms if alarms_changed else None,
                 "diagnostics": new_diags, "tracks": new_points}
        tracks = {a: tuple(tr.sealed) + ((_dumps(tr.tail)[1:-1],) if tr.tail else ())
                  for a, tr in sorted(self._tracks.items())}
        snap = Snapshot(seq, _dumps(head)[1:-1], tracks, _dumps(delta))
        with self.cond:
            self.snapshot = snap
            self._deltas.append((seq, snap.delta))
            self.cond.notify_all()

    def _add_point(self, agent: str, row: list) -> None:
        tr = self._tracks.setdefault(agent, _Track())
        tr.tail.append(row)
        if len(tr.tail) >= CHUNK:
            tr.sealed.append(_dumps(tr.tail)[1:-1])
            tr.tail = []
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
