"""Smooth phase profiles with analytic first and second derivatives.

A swing phase runs over a normalised phase ``s`` in [0, 1]. Two families of
polynomials describe how a quantity moves during it:

* :func:`progress` — the regularised incomplete beta function ``I_s(a, b)``: rises
  from 0 to 1; with integer ``a, b >= 3`` its first and second derivatives vanish at
  both ends, so position, velocity *and acceleration* are continuous where the foot
  leaves and reaches stance (the accelerometer sees no jump).
* :func:`bump` — ``s^a (1-s)^b`` scaled to a peak of 1: goes out and comes back
  (foot clearance, toe-off pitch, lateral sway), with the same end conditions.

``a`` and ``b`` place the bulk of the motion: ``a < b`` early, ``a > b`` late.
All functions are vectorised over ``s`` and over per-sample ``a``/``b`` arrays.
"""
from __future__ import annotations

import numpy as np
from scipy import special


def progress(s: np.ndarray, a: np.ndarray | float, b: np.ndarray | float
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``I_s(a, b)`` and its first two derivatives with respect to ``s``."""
    s = np.clip(np.asarray(s, float), 0.0, 1.0)
    a = np.asarray(a, float)
    b = np.asarray(b, float)
    norm = special.beta(a, b)
    f = special.betainc(a, b, s)
    sa2 = s ** (a - 2.0)
    sb2 = (1.0 - s) ** (b - 2.0)
    d1 = sa2 * s * sb2 * (1.0 - s) / norm
    d2 = sa2 * sb2 * ((a - 1.0) * (1.0 - s) - (b - 1.0) * s) / norm
    return f, d1, d2


def bump(s: np.ndarray, a: np.ndarray | float, b: np.ndarray | float
         ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``s^a (1-s)^b`` normalised to a maximum of 1, and its first two derivatives."""
    s = np.clip(np.asarray(s, float), 0.0, 1.0)
    a = np.asarray(a, float)
    b = np.asarray(b, float)
    peak = (a / (a + b)) ** a * (b / (a + b)) ** b
    u = 1.0 - s
    sa2 = s ** (a - 2.0)
    ub2 = u ** (b - 2.0)
    h = a - (a + b) * s
    f = sa2 * s * s * ub2 * u * u / peak
    d1 = sa2 * s * ub2 * u * h / peak
    d2 = sa2 * ub2 * (((a - 1.0) * u - (b - 1.0) * s) * h - (a + b) * s * u) / peak
    return f, d1, d2
