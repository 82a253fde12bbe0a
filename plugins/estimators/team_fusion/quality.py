"""Each input's consistency with the other inputs, learned online: a covariance factor
per firefighter and input stream (never from the truth).

At every fusion step, input ``i`` (horizontal mean ``x_i`` [m], covariance ``P_i``
[m^2] as carried, before this factor) is compared with a reference ``r`` with
covariance ``R``: the fusion of the other inputs of its consistent set, or for an input
left out, the fused pose (see the estimator). ``q = (x_i - r)^T (P_i + R)^-1
(x_i - r) / 2`` has mean 1 when both covariances hold their errors. ``margin`` times an
exponentially weighted mean of ``q`` over ``time_constant`` seconds is the input's
factor, never below 1 and at most ``max_factor``: covariance matching (Mehra 1972) on
the inputs' innovations against each other. The tightest input's reference is the
looser others, so its ``q`` stays small while theirs grows when it contradicts them:
they widen until they agree with it, rather than out-voting it.
"""
from __future__ import annotations

import math

import numpy as np


class InputQuality:
    """One firefighter's covariance factors per input stream."""

    def __init__(self, time_constant: float, max_factor: float, margin: float = 1.0):
        self.time_constant = time_constant      # [s]
        self.max_factor = max_factor
        self.margin = margin
        self._mean: dict[str, float] = {}
        self._t: dict[str, float] = {}

    def factor(self, stream: str) -> float:
        """The factor on ``stream``'s horizontal covariance (1 until learned)."""
        return min(self.max_factor, max(1.0, self.margin * self._mean.get(stream, 0.0)))

    def update(self, stream: str, t: float, mean: np.ndarray, cov: np.ndarray,
               reference: np.ndarray, reference_cov: np.ndarray | None = None) -> None:
        """Add the disagreement at time ``t`` [s] of ``stream``'s ``mean`` (2,) with
        covariance ``cov`` (2, 2) from the ``reference`` position (2,) (with covariance
        ``reference_cov``, added to ``cov``)."""
        dx, dy = float(mean[0] - reference[0]), float(mean[1] - reference[1])
        if reference_cov is not None:
            cov = cov + reference_cov
        a, b, d = float(cov[0, 0]), float(cov[0, 1]), float(cov[1, 1])
        det = a * d - b * b
        if not det > 0:
            return
        q = 0.5 * (d * dx * dx - 2.0 * b * dx * dy + a * dy * dy) / det
        q = min(q, self.max_factor)
        last = self._t.get(stream, t)
        alpha = 1.0 - math.exp(-max(t - last, 0.0) / self.time_constant)
        m = self._mean.setdefault(stream, 0.0)
        self._mean[stream] = m + alpha * (q - m)
        self._t[stream] = t
