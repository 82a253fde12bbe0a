"""The recent odometry track of one firefighter, in the INS frame.

The search-pattern comparison needs the last ``d`` metres of the odometry
trajectory (§IV-D) and the particle filter needs the offset between the IMU yaw and
the walking direction (§IV-E, footnote 4: "at each measurement update the relative
orientation between the inertial measurement unit and the walking direction is
estimated"). Both come from this buffer of INS poses, kept only as far back as
``keep_m`` metres of walking.
"""
from __future__ import annotations

import numpy as np

__all__ = ["OdometryHistory"]


class OdometryHistory:
    """INS-frame poses (t, x, y, z, heading) with their cumulative horizontal path length."""

    def __init__(self, keep_m: float = 60.0, capacity: int = 512):
        self.keep_m = keep_m
        self._t = np.empty(capacity)
        self._pos = np.empty((capacity, 3))
        self._heading = np.empty(capacity)
        self._s = np.empty(capacity)  # cumulative path length [m]
        self._n = 0

    def __len__(self) -> int:
        return self._n

    @property
    def walked_m(self) -> float:
        """Horizontal path length walked since the first pose [m]."""
        return float(self._s[self._n - 1]) if self._n else 0.0

    @property
    def t(self) -> np.ndarray:
        return self._t[:self._n]

    @property
    def position(self) -> np.ndarray:
        """(n, 3) INS positions [m]."""
        return self._pos[:self._n]

    @property
    def heading(self) -> np.ndarray:
        return self._heading[:self._n]

    @property
    def path_length(self) -> np.ndarray:
        return self._s[:self._n]

    def append(self, t: float, position: np.ndarray, heading: float) -> None:
        n = self._n
        if n == len(self._t):
            self._compact()
            n = self._n
            if n == len(self._t):
                self._grow()
        step = float(np.hypot(*(position[:2] - self._pos[n - 1, :2]))) if n else 0.0
        self._t[n] = t
        self._pos[n] = position
        self._heading[n] = heading
        self._s[n] = (self._s[n - 1] if n else 0.0) + step
        self._n = n + 1

    def _compact(self) -> None:
        """Drop poses older than ``keep_m`` of walking (keeping one before the cut)."""
        s = self._s[:self._n]
        first = max(0, int(np.searchsorted(s, s[-1] - self.keep_m, side="right")) - 1)
        if first:
            keep = slice(first, self._n)
            m = self._n - first
            self._t[:m] = self._t[keep]
            self._pos[:m] = self._pos[keep]
            self._heading[:m] = self._heading[keep]
            self._s[:m] = self._s[keep]
            self._n = m

    def _grow(self) -> None:
        cap = 2 * len(self._t)
        for name in ("_t", "_heading", "_s"):
            old = getattr(self, name)
            new = np.empty(cap)
            new[:len(old)] = old
            setattr(self, name, new)
        pos = np.empty((cap, 3))
        pos[:len(self._pos)] = self._pos
        self._pos = pos

    def tail(self, length_m: float, spacing_m: float) -> np.ndarray | None:
        """The last ``length_m`` of the horizontal path resampled every ``spacing_m`` [m].

        Returns (P, 2) INS-frame points ordered in time, ending at the latest pose,
        or None while less than ``length_m`` has been walked. Resampling by path
        length (not time) keeps standing still from weighting one spot more.
        """
        if self._n < 2 or self.walked_m < length_m - 1e-9:
            return None
        s = self.path_length
        targets = s[-1] - length_m + np.arange(int(round(length_m / spacing_m)) + 1) * spacing_m
        targets[-1] = s[-1]
        # s is non-decreasing; drop repeated values so interpolation is well defined
        uniq = np.concatenate([[True], np.diff(s) > 0])
        su, pu = s[uniq], self.position[uniq, :2]
        return np.column_stack([np.interp(targets, su, pu[:, 0]), np.interp(targets, su, pu[:, 1])])

    def walk_offset(self, length_m: float, min_step_m: float = 0.1) -> float | None:
        """IMU yaw minus walking direction [rad] over the last ``length_m`` (footnote 4).

        The length-weighted circular mean of (heading - direction of displacement) over
        the increments of at least ``min_step_m``; None when none qualify.
        """
        if self._n < 2:
            return None
        s = self.path_length
        first = max(0, int(np.searchsorted(s, s[-1] - length_m, side="left")) - 1)
        pos = self.position[first:, :2]
        d = np.diff(pos, axis=0)
        step = np.hypot(d[:, 0], d[:, 1])
        ok = step >= min_step_m
        if not ok.any():
            return None
        heading = self.heading[first + 1:][ok]
        diff = heading - np.arctan2(d[ok, 1], d[ok, 0])
        w = step[ok]
        return float(np.arctan2(w @ np.sin(diff), w @ np.cos(diff)))
