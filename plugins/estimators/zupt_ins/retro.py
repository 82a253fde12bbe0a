"""Retrospective correction of the swing phase (zupt-extension, "ZUPT extension").

Bonestroo et al. observe that when the foot comes to rest and the estimated velocity
is not zero, the error built up during the whole movement phase since the previous
ZUPT, and correct all velocities of that phase retrospectively with weights rising
linearly from 0 to 1. The position correction this implies grows with the integral
of the ramp, i.e. quadratically over the swing: ``c_i = S_i / S_{N+1}`` with
``S_i = i (i + 1) / 2`` for the N swing samples i = 1..N (sample N+1 is the stance
onset itself).

In the error-state Kalman filter the first ZUPT of a stance already corrects the
onset position, through the position-velocity cross-covariance built up during the
swing (for a velocity error growing linearly this is the same -dv*T/2 as the paper's
ramp). What the filter does not revise is the swing samples in between: this module
spreads the onset's position correction (the filter's own, ``E_CORR`` of the step
event, which is written ``step_settle`` later in the stance) back over them with the
paper's ramp. It changes the full-rate track before each stance, not the stances: the
track at a step's time is the step's pose.
"""
from __future__ import annotations

import numpy as np

from . import eskf


def ramp_weights(n: int) -> np.ndarray:
    """Weights (n,) of the swing samples 1..n, reaching 1 at the stance onset n+1."""
    i = np.arange(1, n + 1, dtype=float)
    return i * (i + 1.0) / ((n + 1.0) * (n + 2.0))


def correct_positions(t: np.ndarray, pos: np.ndarray, events: np.ndarray) -> np.ndarray:
    """Positions (N, 3) with each step's onset correction spread over its swing.

    ``t`` (N,) and ``pos`` (N, 3) are full-rate filter output; ``events`` rows use the
    ``eskf.E_*`` columns. Steps whose stance onset is not in ``t`` are skipped, and
    swing samples that are not in ``pos``.
    """
    out = np.array(pos, dtype=float, copy=True)
    for ev in events:
        if int(ev[eskf.E_KIND]) != eskf.EVENT_STEP:
            continue
        n = int(ev[eskf.E_SWING_N])
        k = int(np.searchsorted(t, ev[eskf.E_STANCE_T0]))
        if n <= 0 or k >= len(t) or t[k] != ev[eskf.E_STANCE_T0]:
            continue
        w = ramp_weights(n)
        first = k - n
        if first < 0:
            w = w[-first:]
            first = 0
        out[first:k] += w[:, None] * ev[eskf.E_CORR:eskf.E_CORR + 3]
    return out
