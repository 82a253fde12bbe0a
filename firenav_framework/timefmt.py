"""How a pipeline time is written for a person: a local clock, never UNIX epoch seconds.

The pipeline clock is the measurement time ``t`` [s]. On live links (and their
replays) it is UNIX time (the receive clock, ``transports/clock.py``); in a simulation
it counts from the scenario start. A person reads the first as the local wall-clock
time (``14:03:22``) and the second as the time since the start (``t=12.3 s``). The
rule that tells them apart is one threshold: times from :data:`EPOCH_FROM` on
(2001-09-09) are wall-clock times; no simulated incident lasts 30 years.

The commander's page (``liveview/app.js``, ``clockText``) applies the same rule.
"""
from __future__ import annotations

import math
import time

__all__ = ["EPOCH_FROM", "is_wall_clock", "clock_text", "wall_text"]

#: Pipeline times [s] from this value on are UNIX times (2001-09-09 01:46:40 UTC).
EPOCH_FROM = 1.0e9


def is_wall_clock(t: float) -> bool:
    """Whether pipeline time ``t`` [s] is a UNIX wall-clock time (a live link's clock)."""
    return math.isfinite(t) and t >= EPOCH_FROM


def wall_text(unix_s: float, *, date: bool = False) -> str:
    """A UNIX time [s] as the local clock, ``14:03:22`` (``2026-12-01 14:03:22`` with
    ``date``), in the machine's time zone."""
    lt = time.localtime(unix_s)
    return time.strftime("%Y-%m-%d %H:%M:%S" if date else "%H:%M:%S", lt)


def clock_text(t: float, *, date: bool = False) -> str:
    """Pipeline time ``t`` [s] for a person: the local clock for a wall-clock time, else
    ``t=12.3 s`` from the start of the data (``t=?`` when not finite)."""
    if not math.isfinite(t):
        return "t=?"
    if is_wall_clock(t):
        return wall_text(t, date=date)
    return f"t={t:.1f} s"
