"""Retrospective correction of the swing phase (zupt-extension, "ZUPT extension").

Bonestroo et al. observe that when the foot comes to rest and the estimated velocity
is not zero, the error built up during the whole movement phase since the previous
ZUPT, and correct all velocities of that phase retrospectively with weights rising
linearly from 0 to 1. The position correction this implies grows with the integral
of the ramp, i.e. quadratically over the swing: ``c_i = S_i / S_{N+1}`` with
``S_i = i (i + 1) / 2`` for the N swing samples i = 1..N (sample N+1 is the stance
onset itself).

In the error-state Kalman filter the zero-velocity updates of a stance already correct
its position, through the position-velocity cross-covariance built up during the swing
(for a velocity error growing linearly this is the same -dv*T/2 as the paper's ramp).
The step event is written ``step_settle`` into the stance (or at its end), when those
updates have settled, with the position correction they made since the stance began
(``E_CORR``). What the filter does not revise is the swing samples before the stance:
this module spreads that correction back over them with the paper's ramp, and holds the
stance's first samples (onset to event) at the step's position, so that the full-rate
track passes through every step pose exactly. It changes the full-rate track, not the
step increments.
"""
from __future__ import annotations

import numpy as np

from . import eskf


def ramp_weights(n: int) -> np.ndarray:
    """Weights (n,) of the swing samples 1..n, reaching 1 at the stance onset n+1."""
    i = np.arange(1, n + 1, dtype=float)
    return i * (i + 1.0) / ((n + 1.0) * (n + 2.0))


def correct_positions(t: np.ndarray, pos: np.ndarray, events: np.ndarray) -> np.ndarray:
    """Positions (N, 3) with each step's correction spread over its swing and its stance
    held at the step's position up to the event.

    ``t`` (N,) and ``pos`` (N, 3) are full-rate filter output; ``events`` rows use the
    ``eskf.E_*`` columns. Steps whose stance onset is not in ``t`` are skipped, and
    swing samples that are not in ``pos``.
    """
    out = np.array(pos, dtype=float, copy=True)
    for ev in events:
        if int(ev[eskf.E_KIND]) != eskf.EVENT_STEP:
            continue
        k = int(np.searchsorted(t, ev[eskf.E_STANCE_T0]))
        if k >= len(t) or t[k] != ev[eskf.E_STANCE_T0]:
            continue
        e = int(np.searchsorted(t, ev[eskf.E_T], side="right"))
        out[k:e] = ev[eskf.E_POS:eskf.E_POS + 3]
        n = int(ev[eskf.E_SWING_N])
        if n <= 0:
            continue
        w = ramp_weights(n)
        first = k - n
        if first < 0:
            w = w[-first:]
            first = 0
        out[first:k] += w[:, None] * ev[eskf.E_CORR:eskf.E_CORR + 3]
    return out
