"""Which share of a step's samples the sensor marked saturated.

A saturated sample (``ImuBlock.flags`` bit ``saturated``: at the device's full scale,
accelerometer or gyro) reads less than the foot did, by an amount nobody knows; the
strapdown integration of a swing with many of them is not what the foot did (on the
simulator's 4 m/s run, a fifth of the samples clipped: steps a third short, step after
step). :class:`ClipLog` keeps the sample times and flags of one IMU until the steps that
span them are out, and tells each step the share of its samples that were saturated.
"""
from __future__ import annotations

import numpy as np

__all__ = ["ClipLog"]


class ClipLog:
    """Sample times [s] and saturation marks of one IMU, consumed step by step.

    Memory is bounded however long the foot stands without a step: samples more than
    ``horizon`` [s] older than the newest block are kept as counts only (how many, how
    many saturated, over which span), which the step overlapping that span counts in full
    (a whole recording logged in one block is kept sample by sample).
    """

    def __init__(self, horizon: float = 10.0) -> None:
        self.horizon = horizon
        self._t = np.zeros(0)
        self._clipped = np.zeros(0, dtype=bool)
        self._old_n = 0                  # samples folded into counts ...
        self._old_clipped = 0            # ... of which saturated ...
        self._old_span = (np.inf, -np.inf)  # ... logged over [first, last] [s]

    def add(self, t: np.ndarray, clipped: np.ndarray | None) -> None:
        """Log samples at times ``t`` (N,) [s], increasing and later than those logged;
        ``clipped`` (N,) bool marks the saturated ones (None: none). Samples logged before
        this block and more than ``horizon`` older than its first are kept as counts."""
        t = np.asarray(t, float)
        if len(t) and len(self._t) and t[0] - self._t[0] > self.horizon:
            k = int(np.searchsorted(self._t, t[0] - self.horizon))
            self._fold(k)
        mark = np.zeros(len(t), dtype=bool) if clipped is None else np.asarray(clipped, bool)
        self._t = np.concatenate((self._t, t))
        self._clipped = np.concatenate((self._clipped, mark))

    def _fold(self, k: int) -> None:
        """Keep the first ``k`` logged samples as counts only."""
        if k == 0:
            return
        self._old_n += k
        self._old_clipped += int(np.count_nonzero(self._clipped[:k]))
        self._old_span = (min(self._old_span[0], float(self._t[0])), float(self._t[k - 1]))
        self._t, self._clipped = self._t[k:], self._clipped[k:]

    def share(self, t_start: float, t_end: float) -> float:
        """Share [0, 1] of the logged samples in (``t_start``, ``t_end``] that were
        saturated (0 without samples); samples up to ``t_end`` are then forgotten (steps
        come in time order, the next one starts where this one ends)."""
        i, j = np.searchsorted(self._t, (t_start, t_end), side="right")
        n, c = int(j - i), int(np.count_nonzero(self._clipped[i:j]))
        first, last = self._old_span
        if self._old_n and t_start < last and t_end >= first:
            n, c = n + self._old_n, c + self._old_clipped
        if t_end >= last:
            self._old_n, self._old_clipped, self._old_span = 0, 0, (np.inf, -np.inf)
        self._t, self._clipped = self._t[j:], self._clipped[j:]
        return c / n if n > 0 else 0.0
