"""Gait classes of the RFID/MEMS paper from foot-IMU odometry ("MEMS Navigation Module").

The paper classifies each step as Forward Walking (FW), Stair Climbing (SC), Stair Descent
Forward (SDF) or Stair Descent Backward (SDB, the firefighters' way down) with 26 fuzzy
rules on shank and thigh sensors, and counts stairs at a nominal 20 cm each for the
height. We only have a foot IMU, whose INS gives one odometry increment per stride of
the instrumented foot, so the classes come from the stride's own motion:

* the stride's height change ``dz`` is first cleared of the INS's vertical drift. A
  small tilt error of the INS navigation frame makes ``dz`` grow in proportion to the
  horizontal displacement (``dz_err = g . d``, a few cm per metre on MEMS of the paper's
  era). ``g`` (2,) is learnt by exponentially weighted least squares on level strides;
* a stride is a stair candidate when its corrected rise and its slope (rise over
  horizontal length; stairs are 30-40 deg, far above the drift gradient) pass a
  threshold: *strong* (half a stair, slope 0.2) or *weak* (0.3 stair, slope 0.12). The
  INS's vertical error on one stride is a good fraction of a stair, so a flight needs
  two consecutive same-sign candidates, at least one strong. A lone candidate counts at
  once (provisionally: the first stride of a flight is a short partial one, and a floor
  boundary may lie on the landing it leaves) and is *retracted* when the next stride
  does not confirm the flight; once in a flight, strong strides of the same sign
  continue it;
* with a building, stairs are only where the building has them: a stride that does not
  end near a stair's footprint is level (``near_stairs`` False), whatever its rise;
* a descent is backward when the stride moves against the toe direction (the foot
  heading plus the mounting yaw, learnt from forward-walking strides);
* ``still``: strides shorter than a few centimetres (rest events).

Stairs are counted per stride as the nearest whole number of stairs of the rise, at
least one and at most ``max_per_stride`` (a stride of the instrumented foot is two steps
of the person, one stair each: firefighters in gear do not skip stairs).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["GAITS", "STAIR_GAITS", "GaitConfig", "StrideGait", "GaitClassifier", "count_stairs"]

#: Gait classes: still, forward walking, stair climbing, stair descent forward / backward.
GAITS = ("still", "FW", "SC", "SDF", "SDB")
#: The gait classes that walk stairs.
STAIR_GAITS = ("SC", "SDF", "SDB")


@dataclass(frozen=True)
class GaitConfig:
    """Thresholds of the stride classifier (SI units)."""

    step_height: float = 0.20     # [m] nominal stair rise (paper: 20 cm)
    min_rise: float = 0.5         # strong candidate: corrected rise >= this many stairs
    stair_slope: float = 0.2      # strong candidate: |rise| / horizontal length >= this
    weak_rise: float = 0.3        # weak candidate: rise >= this many stairs
    weak_slope: float = 0.12      # weak candidate: slope >= this
    level_slope: float = 0.15     # level stride (teaches the drift gradient): slope below
    still_distance: float = 0.05  # [m] shorter strides are 'still'
    memory: float = 20.0          # [strides] time constant of the drift-gradient estimate
    prior: float = 1.0            # [m^2] weight of the zero-gradient prior


@dataclass(frozen=True)
class StrideGait:
    """The class of one stride, its drift-corrected height change [m], its horizontal
    displacement (2,) [m] as given, and ``retract``: True when the previous stride was
    counted as stairs provisionally and this one shows it was not."""

    gait: str
    dz: float
    d: np.ndarray
    retract: bool = False


def count_stairs(dz: float, step_height: float, max_per_stride: int = 2) -> int:
    """Signed number of stairs in a stair stride of height change ``dz`` [m]: the nearest
    whole number, at least one, at most ``max_per_stride``."""
    n = min(max(1, round(abs(dz) / step_height)), max_per_stride)
    return int(math.copysign(n, dz))


class GaitClassifier:
    """Per-agent stride classifier with its drift-gradient and mounting-yaw estimates."""

    #: Forward-walking strides needed, and their length, before the mounting yaw is used.
    YAW_MIN_STRIDES = 3
    YAW_MIN_LENGTH = 0.3  # [m]

    def __init__(self, config: GaitConfig | None = None):
        self.cfg = config or GaitConfig()
        self._A = np.eye(2) * self.cfg.prior     # weighted sum d d^T (+ prior)
        self._b = np.zeros(2)                     # weighted sum d dz
        self._yaw = np.zeros(2)                   # sum of unit vectors (step dir - foot yaw)
        self._yaw_n = 0
        self._run = 0                             # sign of the flight being walked, 0: none
        self._pending: tuple[int, bool] | None = None   # (sign, strong) of a provisional stair stride

    @property
    def gradient(self) -> np.ndarray:
        """Estimated vertical drift per metre walked (2,) [m/m] in the odometry frame."""
        return np.linalg.solve(self._A, self._b)

    @property
    def mount_yaw(self) -> float:
        """Walking direction minus foot heading [rad] on forward strides (0 until known)."""
        if self._yaw_n < self.YAW_MIN_STRIDES:
            return 0.0
        return math.atan2(self._yaw[1], self._yaw[0])

    def classify(self, delta: np.ndarray, foot_heading: float, near_stairs: bool = True
                 ) -> StrideGait:
        """Class of a stride with displacement ``delta`` (3,) [m] (odometry frame), foot
        heading [rad] at mid-stride (same frame); ``near_stairs`` False when the building
        has no stair where the stride ends."""
        cfg = self.cfg
        d = np.asarray(delta[:2], float)
        length = float(math.hypot(d[0], d[1]))
        if math.sqrt(length ** 2 + float(delta[2]) ** 2) < cfg.still_distance:
            return StrideGait("still", 0.0, d)
        dz = float(delta[2]) - float(self.gradient @ d)
        sign = 1 if dz > 0 else -1
        strong = near_stairs and abs(dz) >= cfg.min_rise * cfg.step_height \
            and abs(dz) >= cfg.stair_slope * length
        weak = strong or (near_stairs and abs(dz) >= cfg.weak_rise * cfg.step_height
                          and abs(dz) >= cfg.weak_slope * length)
        pending, self._pending = self._pending, None
        if strong and self._run == sign:
            return StrideGait(self._stair_class(d, dz, foot_heading), dz, d)
        self._run = 0
        if weak and pending is not None and pending[0] == sign and (strong or pending[1]):
            self._run = sign
            return StrideGait(self._stair_class(d, dz, foot_heading), dz, d)
        retract = pending is not None
        if weak:
            self._pending = (sign, strong)
            return StrideGait(self._stair_class(d, dz, foot_heading), dz, d, retract)
        if length > 0 and abs(dz) < cfg.level_slope * length:
            f = math.exp(-1.0 / cfg.memory)
            self._A = f * self._A + np.outer(d, d) + (1 - f) * np.eye(2) * cfg.prior
            self._b = f * self._b + d * float(delta[2])
        if length >= self.YAW_MIN_LENGTH:
            off = math.atan2(d[1], d[0]) - foot_heading
            self._yaw += (math.cos(off), math.sin(off))
            self._yaw_n += 1
        return StrideGait("FW", dz, d, retract)

    def _stair_class(self, d: np.ndarray, dz: float, foot_heading: float) -> str:
        if dz > 0:
            return "SC"
        toe = foot_heading + self.mount_yaw
        along = d[0] * math.cos(toe) + d[1] * math.sin(toe)
        return "SDB" if along < 0.0 else "SDF"
