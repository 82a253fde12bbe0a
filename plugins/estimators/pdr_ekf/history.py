"""The recent strides of one agent, to place a tag event that is processed late.

Tag detections come out of the reader after the pass is over (the strongest read may be
seconds old) and every event waits for the next synchronous update, so measurements refer
to an earlier time than the filter's state. :class:`StrideHistory` keeps the strides'
MEMS displacements (building frame before the heading perturbation) with running sums,
and answers "how far has the agent walked since time t" with its covariance, which the
position update of :mod:`.filter` turns into a delayed measurement model.
"""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

__all__ = ["Stride", "StrideHistory"]


@dataclass(frozen=True)
class Stride:
    """One stride: times [s], MEMS displacement ``d`` (2,) [m], height change [m], its
    covariance (2, 2) [m^2], gait class, and the running sums up to its end."""

    t_start: float
    t: float
    d: np.ndarray
    dz: float
    cov: np.ndarray
    gait: str
    cum_d: np.ndarray
    cum_z: float
    cum_cov: np.ndarray


class StrideHistory:
    """The last ``maxlen`` strides with running sums."""

    def __init__(self, maxlen: int = 2000):
        self.strides: deque[Stride] = deque(maxlen=maxlen)

    def add(self, t_start: float, t: float, d: np.ndarray, dz: float, cov: np.ndarray,
            gait: str) -> Stride:
        if self.strides:
            last = self.strides[-1]
            cum_d, cum_z, cum_cov = last.cum_d + d, last.cum_z + dz, last.cum_cov + cov
        else:
            cum_d, cum_z, cum_cov = d.copy(), dz, cov.copy()
        s = Stride(t_start, t, d, dz, cov, gait, cum_d, cum_z, cum_cov)
        self.strides.append(s)
        return s

    @property
    def t_end(self) -> float:
        return self.strides[-1].t if self.strides else -np.inf

    def covers(self, t: float) -> bool:
        """Whether time ``t`` [s] is not older than the oldest stride kept."""
        return bool(self.strides) and t >= self.strides[0].t_start

    def since(self, t: float) -> tuple[np.ndarray, float, np.ndarray]:
        """(displacement (2,) [m], height change [m], covariance (2, 2) [m^2]) from time
        ``t`` [s] to the end of the last stride; a stride spanning ``t`` counts pro rata."""
        if not self.strides or t >= self.strides[-1].t:
            return np.zeros(2), 0.0, np.zeros((2, 2))
        last = self.strides[-1]
        ends = [s.t for s in self.strides]
        k = int(np.searchsorted(ends, t, side="right"))   # first stride ending after t
        s = self.strides[k]
        before_d = s.cum_d - s.d
        before_z = s.cum_z - s.dz
        before_c = s.cum_cov - s.cov
        span = s.t - s.t_start
        frac = 0.0 if span <= 0 else min(1.0, max(0.0, (t - s.t_start) / span))
        at_d = before_d + frac * s.d
        at_z = before_z + frac * s.dz
        at_c = before_c + frac * s.cov
        return last.cum_d - at_d, last.cum_z - at_z, last.cum_cov - at_c

    def after(self, t: float) -> list[Stride]:
        """The strides that end after time ``t`` [s], oldest first."""
        return [s for s in self.strides if s.t > t]
