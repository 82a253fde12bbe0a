"""A firefighter's recent building-frame odometry: where the INS says they went between
two instants, to carry an older pose estimate forward to the fusion time."""
from __future__ import annotations

import bisect
from collections import deque

import numpy as np

from firenav_framework.geometry import wrap_angle


class OdometryTrail:
    """The last ``keep_s`` seconds of absolute odometry poses (building frame).

    Positions [m] ENU and headings [rad] at the odometry's step times [s].
    """

    def __init__(self, keep_s: float):
        self.keep_s = keep_s
        self._t: deque[float] = deque()
        self._rows: deque[tuple[float, float, float, float]] = deque()   # x, y, z, heading

    def __len__(self) -> int:
        return len(self._t)

    @property
    def last_t(self) -> float:
        return self._t[-1] if self._t else -np.inf

    def add(self, t: float, position: np.ndarray, heading: float) -> None:
        self._t.append(t)
        self._rows.append((float(position[0]), float(position[1]), float(position[2]),
                           float(heading)))
        while self._t and self._t[0] < t - self.keep_s:
            self._t.popleft()
            self._rows.popleft()

    def _at(self, t: float) -> tuple[np.ndarray, float]:
        """Position (interpolated, clamped to the trail's ends) and heading (of the next
        step) at ``t``."""
        ts = self._t
        i = bisect.bisect_left(ts, t)
        if i <= 0:
            r = self._rows[0]
            return np.array(r[:3]), r[3]
        if i >= len(ts):
            r = self._rows[-1]
            return np.array(r[:3]), r[3]
        t0, t1 = ts[i - 1], ts[i]
        r0, r1 = self._rows[i - 1], self._rows[i]
        f = (t - t0) / (t1 - t0) if t1 > t0 else 1.0
        return np.array([r0[k] + f * (r1[k] - r0[k]) for k in range(3)]), r1[3]

    def motion(self, t0: float, t1: float) -> tuple[np.ndarray, float, float]:
        """``(shift (3,), heading change, heading at t0)`` of the odometry from ``t0`` to ``t1``."""
        p0, h0 = self._at(t0)
        p1, h1 = self._at(t1)
        return p1 - p0, wrap_angle(h1 - h0), h0
