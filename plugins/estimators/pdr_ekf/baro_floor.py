"""The floor from a barometer: a missed or phantom flight put right without a stair map.

The height of the filter is a floor level plus counted stairs (or the building's
flights). That is exact while the stairs are counted right, and off by a whole storey
when a flight was missed or invented. A barometer's height (``PressureHeight``,
docs/barometer.md) is the other way round: its absolute value carries a slowly changing
offset (the zeroing's error and what zeroing cannot remove: fire, open doors, the stack
effect: about 0.85 m, correlated over minutes), but it never loses a storey.

Counted stairs are the weak part (a consumer foot IMU misses or invents whole flights),
the barometer's offset is the weak part of the other, so:

* the height **follows the barometer**, offset removed: ``Z = height_baro - offset`` at
  every report (the floor changes as the agent climbs, not after), except while the
  filter follows a flight of the building's stair map (exact there);
* the agent is *on a level* while the barometer's heights over the last ``window``
  seconds span less than ``still_range`` (a stair is 0.15-0.2 m, a stride two of them)
  and no stride of that window was classed as stairs (a slow climb, a pause on a
  flight: the barometer alone would take it for a level and teach the offset part of
  the climb);
* on a level the offset is learnt towards ``height_baro - L``, ``L`` the floor level
  nearest to the barometer's height when that is within ``gate``, by a scalar Kalman
  filter whose state is a random walk (``offset_rw``: doors and fire move it over
  minutes): the height settles exactly on the floor's level, and the offset never
  learns a storey (a level farther than ``gate`` teaches nothing). Landings are not
  candidates: a walk rests on one only between two flights.
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

import numpy as np

__all__ = ["BaroConfig", "BaroFloor"]


@dataclass(frozen=True)
class BaroConfig:
    """``gate`` [m]: how near a floor's level the barometer must be to learn its offset
    there; ``window`` [s] and ``still_range`` [m]: on a level; ``offset_sigma`` [m] the
    offset's initial 1-sigma; ``offset_rw`` [m/sqrt(s)] its random walk; ``noise`` [m]
    the short-term noise of one height report. The values (and their defaults) are the
    pdr_ekf ``barometer`` parameters' (``params.Barometer.config``)."""

    gate: float
    window: float
    still_range: float
    offset_sigma: float
    offset_rw: float
    noise: float


@dataclass
class BaroFloor:
    """The barometer's offset for one agent and its recent heights."""

    cfg: BaroConfig
    offset: float = 0.0
    var: float = math.nan
    t: float = -math.inf
    recent: deque = field(default_factory=deque)    # (t [s], height [m])

    def __post_init__(self) -> None:
        if math.isnan(self.var):
            self.var = self.cfg.offset_sigma ** 2

    def on_level(self) -> bool:
        """Whether the recent heights say the agent walks (or stands) on a level."""
        if not self.recent or self.recent[-1][0] - self.recent[0][0] < 0.75 * self.cfg.window:
            return False
        h = [r[1] for r in self.recent]
        return max(h) - min(h) < self.cfg.still_range

    def update(self, t: float, height: float, levels: np.ndarray, learn: bool = True
               ) -> tuple[float, float]:
        """A barometer ``height`` [m] (building z) at ``t`` [s]; ``levels`` the floor
        levels [m]; ``learn``: no stair stride within the window (the offset may be
        learnt). The agent's height [m] and its variance [m^2] (module docstring)."""
        c = self.cfg
        if math.isfinite(self.t):
            self.var += c.offset_rw ** 2 * max(0.0, t - self.t)
        self.t = t
        self.recent.append((t, height))
        while self.recent and self.recent[0][0] < t - c.window:
            self.recent.popleft()
        if learn and len(levels) and self.on_level():
            mean = float(np.mean([r[1] for r in self.recent]))
            level = float(levels[np.argmin(np.abs(levels - (mean - self.offset)))])
            if abs(mean - self.offset - level) <= c.gate:
                k = self.var / (self.var + c.noise ** 2)
                self.offset += k * ((mean - level) - self.offset)
                self.var *= 1.0 - k
        return height - self.offset, self.var + c.noise ** 2
