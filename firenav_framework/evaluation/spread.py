"""The spread of a figure over runs: min / median / max and a 95 % interval.

Each run's figure is computed from that run alone (all its agents pooled, see
:func:`run_figures`); the spread describes how those per-run figures vary over the
seeds. The interval is the distribution-free 95 % confidence interval of the median
from order statistics: with the per-run values sorted, ``[x_(k), x_(n+1-k)]`` for the
largest ``k`` with ``P(Binomial(n, 1/2) < k) <= 2.5 %``. It needs at least 6 runs
(for 5, even ``[min, max]`` covers the median only 93.75 % of the time) and states no
shape of the distribution. For 30 runs it is ``[x_(10), x_(21)]``.

A run that never converged has ``converge_s`` (``variance_converge_s``) = None; here it counts as infinitely
late (so the median is "never" when half the runs never converged). Other figures
that do not apply to a run (no floors, no z) are left out of their spread.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Iterable

import numpy as np

from .metrics import CONVERGE_BOUND_M, KEYS, TIME_KEYS, TrackMetrics, pooled_metrics

#: Coverage of the interval of the median.
LEVEL = 0.95


@dataclass(frozen=True)
class Spread:
    """Per-run values of one figure: how many, min, median, max, the 95 % interval."""

    n: int
    min: float | None
    median: float | None
    max: float | None
    ci_low: float | None
    ci_high: float | None

    def as_dict(self) -> dict:
        """JSON form; infinite values (never converged) become None."""
        return {k: (None if isinstance(v, float) and not math.isfinite(v) else v)
                for k, v in asdict(self).items()}


def median_interval_ranks(n: int, level: float = LEVEL) -> tuple[int, int] | None:
    """1-based ranks ``(k, n + 1 - k)`` of the distribution-free interval of the median."""
    from scipy.stats import binom
    alpha = (1.0 - level) / 2.0
    k = 0
    while k + 1 <= n // 2 and binom.cdf(k, n, 0.5) <= alpha:
        k += 1
    return (k, n + 1 - k) if k >= 1 else None


def spread(values: Iterable[float | None], *, none_is_inf: bool = False) -> Spread:
    """Spread of per-run values (None: not applicable, or infinity with ``none_is_inf``)."""
    vals = [math.inf if v is None and none_is_inf else v for v in values]
    x = np.sort(np.array([v for v in vals if v is not None and not math.isnan(v)], float))
    n = int(x.size)
    if n == 0:
        return Spread(0, None, None, None, None, None)
    ranks = median_interval_ranks(n)
    lo, hi = (float(x[ranks[0] - 1]), float(x[ranks[1] - 1])) if ranks else (None, None)
    # median of values that may include +inf: the middle order statistics
    med = float(x[n // 2]) if n % 2 else float(0.5 * (x[n // 2 - 1] + x[n // 2]))
    return Spread(n, float(x[0]), med, float(x[-1]), lo, hi)


def run_figures(errors: list, bound_m: float = CONVERGE_BOUND_M) -> TrackMetrics:
    """One run's figures: the errors of all its agents pooled."""
    return pooled_metrics(list(errors), bound_m)


def spreads(per_run: list[TrackMetrics]) -> dict[str, Spread]:
    """The spread of every reported figure (:data:`.metrics.KEYS`) over runs."""
    return {k: spread([getattr(m, k) for m in per_run], none_is_inf=(k in TIME_KEYS))
            for k in KEYS}
