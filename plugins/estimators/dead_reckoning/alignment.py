"""The pieces of the eq. 9 alignment that look at the first steps or the ground truth.

Step lists are ``(Odometry, delta)`` pairs in the INS frame, ``delta`` (3,) [m] the
increment as integrated (gaps bridged).
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["imu_yaw_offset", "straight_chord", "truth_at"]

#: A step turning by at most this much [rad] counts as straight.
STRAIGHT_TURN = math.radians(5)


def imu_yaw_offset(steps: list, n: int, final: bool) -> float | None:
    """Walking direction minus INS heading [rad]: the circular mean of (step direction -
    INS heading at mid-step) over the first ``n`` straight forward steps (the previous step
    straight too: a stride that rounds a corner lags the foot's heading), i.e. the IMU's
    yaw on the boot plus the toe-out. None: not enough steps yet (0 at the end of input
    when there are none at all)."""
    diffs, straight_before = [], False
    for msg, delta in steps:
        forward = (np.hypot(*delta[:2]) >= 0.3 and abs(msg.dheading) <= STRAIGHT_TURN
                   and msg.motion in ("", "walk"))
        if forward and straight_before:
            diffs.append(math.atan2(delta[1], delta[0]) - (msg.heading - 0.5 * msg.dheading))
        straight_before = forward or (np.hypot(*delta[:2]) < 0.05
                                      and abs(msg.dheading) <= STRAIGHT_TURN and straight_before)
        if len(diffs) == n:
            break
    if len(diffs) < n and not final:
        return None
    if not diffs:
        return 0.0
    return math.atan2(np.mean(np.sin(diffs)), np.mean(np.cos(diffs)))


def straight_chord(deltas: np.ndarray, tolerance: float) -> np.ndarray:
    """Chord (3,) of the longest straight prefix of a path given by its increments.

    The prefix ends where a point strays more than ``tolerance`` [m] sideways from the
    chord from the start to that point's successor.
    """
    pts = np.vstack([np.zeros(3), np.cumsum(deltas, axis=0)])
    best = pts[1] - pts[0] if len(pts) > 1 else np.zeros(3)
    for k in range(2, len(pts)):
        chord = pts[k, :2]
        n = float(np.hypot(*chord))
        if n == 0.0:
            continue
        side = np.abs(pts[1:k, 0] * chord[1] - pts[1:k, 1] * chord[0]) / n
        if np.any(side > tolerance):
            break
        best = pts[k] - pts[0]
    return best


def truth_at(samples: list, t: float, final: bool) -> tuple[np.ndarray, float | None] | None:
    """The true pose at time ``t`` [s] from (t, x, y, z, heading) samples: the last one at
    or before ``t`` (the first one if all are later), once a later sample shows that no
    closer one will come (or at the end of input). Heading None when not finite."""
    if not samples or (samples[-1][0] < t and not final):
        return None
    before = [s for s in samples if s[0] <= t]
    _, x, y, z, h = before[-1] if before else samples[0]
    return np.array([x, y, z]), (h if math.isfinite(h) else None)
