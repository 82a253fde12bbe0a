"""Track error against ground truth.

Errors are computed at the estimate's own times, against the ground truth
interpolated linearly to those times (truth is sampled much faster than estimates).
Only estimates inside the truth's time span count.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from ..tracks import Track


def horizontal_errors(track: Track, truth: Track) -> tuple[np.ndarray, np.ndarray]:
    """(times, horizontal error [m]) of ``track`` against ``truth``."""
    if len(track) == 0 or len(truth) < 2:
        return np.empty(0), np.empty(0)
    inside = (track.t >= truth.t[0]) & (track.t <= truth.t[-1])
    t = track.t[inside]
    tx = np.interp(t, truth.t, truth.position[:, 0])
    ty = np.interp(t, truth.t, truth.position[:, 1])
    return t, np.hypot(track.position[inside, 0] - tx, track.position[inside, 1] - ty)


@dataclass(frozen=True)
class ErrorStats:
    """Summary statistics of a horizontal error series [m]."""

    n: int
    rmse_m: float
    mean_m: float
    median_m: float
    p90_m: float
    p95_m: float
    max_m: float

    def as_dict(self) -> dict:
        return asdict(self)


def error_stats(errors: np.ndarray) -> ErrorStats:
    e = np.asarray(errors, float)
    e = e[np.isfinite(e)]
    if e.size == 0:
        nan = math.nan
        return ErrorStats(0, nan, nan, nan, nan, nan, nan)
    return ErrorStats(n=int(e.size), rmse_m=float(np.sqrt(np.mean(e ** 2))),
                      mean_m=float(e.mean()), median_m=float(np.median(e)),
                      p90_m=float(np.percentile(e, 90)), p95_m=float(np.percentile(e, 95)),
                      max_m=float(e.max()))
