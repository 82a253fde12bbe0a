"""One tag-anchor link of the ``uwb`` sensor: its range track and its outlier gate."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .params import Gate

__all__ = ["Link", "RangeTrack"]


class RangeTrack:
    """Constant-velocity Kalman filter on one link's range: state (range [m], rate [m/s]).

    Walking changes a range smoothly; a range that jumps *longer* than the track allows
    is the signature of a blocked direct path (NLOS adds delay, never removes it).
    """

    def __init__(self, t: float, r: float, sigma: float, max_rate: float):
        self.t = t
        self.x = np.array([r, 0.0])
        self.P = np.diag([sigma ** 2, max_rate ** 2])

    def innovation(self, t: float, r: float, sigma: float, accel: float) -> tuple[float, float]:
        """Predict to ``t``; (innovation [m], its standard deviation [m])."""
        dt = max(t - self.t, 0.0)
        f = np.array([[1.0, dt], [0.0, 1.0]])
        g = np.array([0.5 * dt * dt, dt])
        self.x = f @ self.x
        self.P = f @ self.P @ f.T + np.outer(g, g) * accel ** 2
        self.t = t
        return r - self.x[0], math.sqrt(self.P[0, 0] + sigma ** 2)

    def update(self, r: float, sigma: float) -> None:
        s = self.P[0, 0] + sigma ** 2
        k = self.P[:, 0] / s
        self.x = self.x + k * (r - self.x[0])
        self.P = self.P - np.outer(k, self.P[0, :])


@dataclass
class Link:
    """One tag-anchor pair: what was last heard and accepted, and its range track."""

    last_t: float | None = None                    # time of the last report, accepted or not
    accepted: tuple[float, float] | None = None    # (t, range) of the last accepted range
    rejects: list = field(default_factory=list)    # consecutive rejected (t, range)
    silent: bool = False
    track: RangeTrack | None = None                # smoothed range and range rate

    def gate(self, t: float, r: float, sigma: float, gate: Gate) -> str:
        """Motion-bounded outlier test of range ``r`` [m] at ``t`` [s]: ``"accepted"``,
        ``"relocked"`` (after ``gate.relock_after`` consistent rejects; the track
        restarts) or ``"rejected"``."""
        def fits(t0: float, r0: float) -> bool:
            return abs(r - r0) <= gate.max_speed * abs(t - t0) + gate.sigmas * sigma * math.sqrt(2)

        if self.accepted is None or fits(*self.accepted):
            self.accepted, self.rejects = (t, r), []
            return "accepted"
        if self.rejects and not fits(*self.rejects[-1]):
            self.rejects = []
        self.rejects.append((t, r))
        if len(self.rejects) >= gate.relock_after:
            self.accepted, self.rejects, self.track = (t, r), [], None
            return "relocked"
        return "rejected"
