"""The paper's reading of a wall contact: the angle of the step to the wall (§2.2).

Pure geometry shared by the rules of :class:`~.constraint.OrcaConstraint`: the angle at
which a step meets a wall, where it crosses the wall's line, and which rule an angle
falls under (heading error, missed door, too small, blocked).
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["approach_angle", "line_crossing", "classify_rotation"]

#: Angles this close to a threshold [rad] count as on it (bands are inclusive).
_ANGLE_EPS = 1e-9


def approach_angle(move: np.ndarray, wall: np.ndarray) -> float:
    """Angle [rad] in [0, pi/2] between a step (2,) and a wall segment (2, 2)."""
    e = wall[1] - wall[0]
    c = abs(float(move[0] * e[0] + move[1] * e[1]))
    s = abs(float(move[0] * e[1] - move[1] * e[0]))
    return math.atan2(s, c)


def line_crossing(pos: np.ndarray, move: np.ndarray, wall: np.ndarray) -> float:
    """Fraction in [0, 1] of the step ``pos`` -> ``pos + move`` where it meets the wall's
    line (1 when it stops short of it)."""
    e = wall[1] - wall[0]
    n = np.array([-e[1], e[0]])
    h0 = float((pos - wall[0]) @ n)
    dh = float(move @ n)
    if h0 * dh >= 0.0 or dh == 0.0:
        return 0.0 if h0 == 0.0 else 1.0
    return min(1.0, -h0 / dh)


def classify_rotation(theta: float, min_rotation: float, max_rotation: float,
                      door_angle: float, door_tolerance: float) -> str:
    """The paper's reading of a correction angle ``theta`` [rad] (§2.2).

    ``"rotation"`` for a heading error to store (min..max), ``"door"`` for a missed door
    (door_angle +- door_tolerance), ``"small"`` below min, ``"blocked"`` otherwise
    (and for NaN: no rotation at the walking speed avoids the walls). All angles [rad].
    """
    a = abs(theta)
    if math.isnan(a):
        return "blocked"
    if a < min_rotation - _ANGLE_EPS:
        return "small"
    if a <= max_rotation + _ANGLE_EPS:
        return "rotation"
    if abs(a - door_angle) <= door_tolerance + _ANGLE_EPS:
        return "door"
    return "blocked"
