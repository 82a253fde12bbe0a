"""A firefighter's recent building-frame odometry: where the INS says they went between
two instants, to carry an older pose estimate forward to the fusion time."""
from __future__ import annotations

from collections import deque

import numpy as np

from firenav_framework.geometry import wrap_angle


class OdometryTrail:
    """The last ``keep_s`` seconds of absolute odometry poses (building frame).

    Positions [m] ENU and headings [rad] at the odometry's step times [s].
    """

    def __init__(self, keep_s: float):
        self.keep_s = keep_s
        self._rows: deque[tuple[float, float, float, float, float]] = deque()

    def __len__(self) -> int:
        return len(self._rows)

    @property
    def last_t(self) -> float:
        return self._rows[-1][0] if self._rows else -np.inf

    def add(self, t: float, position: np.ndarray, heading: float) -> None:
        self._rows.append((t, float(position[0]), float(position[1]), float(position[2]),
                           float(heading)))
        while self._rows and self._rows[0][0] < t - self.keep_s:
            self._rows.popleft()

    def _at(self, t: float) -> tuple[np.ndarray, float]:
        """Position (interpolated, clamped to the trail's ends) and heading (nearest) at ``t``."""
        rows = np.asarray(self._rows)
        ts = rows[:, 0]
        pos = np.array([np.interp(t, ts, rows[:, k]) for k in (1, 2, 3)])
        i = int(np.clip(np.searchsorted(ts, t), 0, len(ts) - 1))
        return pos, float(rows[i, 4])

    def motion(self, t0: float, t1: float) -> tuple[np.ndarray, float, float]:
        """``(shift (3,), heading change, heading at t0)`` of the odometry from ``t0`` to ``t1``."""
        p0, h0 = self._at(t0)
        p1, h1 = self._at(t1)
        return p1 - p0, wrap_angle(h1 - h0), h0
