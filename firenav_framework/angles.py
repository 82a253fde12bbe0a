"""Angles [rad]: one wrapping convention for every estimator."""
from __future__ import annotations

import math

__all__ = ["wrap_angle"]


def wrap_angle(angle: float) -> float:
    """``angle`` [rad] wrapped to (-pi, pi] (exactly; ``-pi`` becomes ``pi``)."""
    a = math.remainder(angle, 2.0 * math.pi)
    return math.pi if a == -math.pi else a
