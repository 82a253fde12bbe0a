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
    """Sample times [s] and saturation marks of one IMU, consumed step by step."""

    def __init__(self) -> None:
        self._t = np.zeros(0)
        self._clipped = np.zeros(0, dtype=bool)

    def add(self, t: np.ndarray, clipped: np.ndarray | None) -> None:
        """Log samples at times ``t`` (N,) [s], increasing and later than those logged;
        ``clipped`` (N,) bool marks the saturated ones (None: none)."""
        mark = np.zeros(len(t), dtype=bool) if clipped is None else np.asarray(clipped, bool)
        self._t = np.concatenate((self._t, np.asarray(t, float)))
        self._clipped = np.concatenate((self._clipped, mark))

    def share(self, t_start: float, t_end: float) -> float:
        """Share [0, 1] of the logged samples in (``t_start``, ``t_end``] that were
        saturated (0 without samples); samples up to ``t_end`` are then forgotten (steps
        come in time order, the next one starts where this one ends)."""
        i, j = np.searchsorted(self._t, (t_start, t_end), side="right")
        n = j - i
        out = float(np.count_nonzero(self._clipped[i:j]) / n) if n > 0 else 0.0
        self._t, self._clipped = self._t[j:], self._clipped[j:]
        return out
