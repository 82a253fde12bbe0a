"""Bad readings of a worn barometer: a stuck sensor and pressure jumps.

A live MEMS barometer's noise (1-2 Pa) moves its last digit: ``stuck_readings``
identical readings in a row mean it has stopped converting (a frozen register, a lost
bus), and its readings are skipped until it changes. A reading further from the last
good one than ``max_step + max_rate * dt`` [Pa] is a jump no wearer makes (a storey is
40 Pa; a fall through a floor stays within ``max_step``); it is skipped. When the
jumped readings stay steady among themselves for ``rejump_s`` seconds the sensor's own
offset has jumped (a reset, a knock, a sealed enclosure), and they are taken on with the
zeroing moved by the jump (``last_shift``), so that the height carries on from before.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

__all__ = ["GuardConfig", "Guard"]

Verdict = Literal["ok", "stuck", "jump", "offset_jump"]


@dataclass(frozen=True)
class GuardConfig:
    """See the module docstring; pressures [Pa], rate [Pa/s], time [s]. The values (and
    their defaults) are the barometer sensor's parameters."""

    stuck_readings: int
    max_step: float
    max_rate: float
    rejump_s: float


@dataclass
class Guard:
    """One barometer's recent readings: the last good one, the run of identical ones
    and a jump under way."""

    last_t: float = math.nan
    last_p: float = math.nan
    same: int = 0
    previous: float = math.nan
    jump_t: float = math.nan
    jump_p: float = math.nan
    jump_last_t: float = math.nan
    last_shift: float = 0.0

    def _near(self, p: float, ref: float, dt: float, cfg: GuardConfig) -> bool:
        return abs(p - ref) <= cfg.max_step + cfg.max_rate * max(dt, 0.0)

    def check(self, t: float, p: float, cfg: GuardConfig) -> Verdict:
        """Judge the reading ``p`` [Pa] at ``t`` [s] (readings in time order)."""
        self.same = self.same + 1 if p == self.previous else 1
        self.previous = p
        if self.same >= cfg.stuck_readings:
            return "stuck"
        if math.isnan(self.last_p) or self._near(p, self.last_p, t - self.last_t, cfg):
            self.last_t, self.last_p = t, p
            self.jump_t = math.nan
            return "ok"
        if math.isnan(self.jump_t) or not self._near(p, self.jump_p, t - self.jump_last_t, cfg):
            self.jump_t = t                     # a new jumped level starts here
        self.jump_p, self.jump_last_t = p, t
        if t - self.jump_t >= cfg.rejump_s:
            self.last_shift = p - self.last_p
            self.last_t, self.last_p = t, p
            self.jump_t = math.nan
            return "offset_jump"
        return "jump"
