"""One receive clock for every live link.

Receive times are UNIX seconds taken from ``time.time()`` once, at import, and then
advanced with the monotonic clock: an NTP step or a manual clock change during a run
cannot make receive times jump. They are integers of microseconds, strictly
increasing across the whole process (two arrivals never share a time, so their order
is the same live and in a replay), and ``us / 1e6`` prints with ``%.6f`` and parses
back to the identical float, which is what makes recorded logs replay exactly.
"""
from __future__ import annotations

import threading
import time

_lock = threading.Lock()
_wall0_us = time.time_ns() // 1000
_mono0_ns = time.monotonic_ns()
_last_us = 0


def now_us() -> int:
    """The current receive time in integer microseconds since the UNIX epoch."""
    global _last_us
    t = _wall0_us + (time.monotonic_ns() - _mono0_ns) // 1000
    with _lock:
        if t <= _last_us:
            t = _last_us + 1
        _last_us = t
    return t


def now() -> float:
    """The current receive time in UNIX seconds (see :func:`now_us`)."""
    return now_us() / 1e6


def seconds(t_us: int) -> float:
    """Receive time in seconds from integer microseconds (the exact inverse of logs)."""
    return t_us / 1e6
