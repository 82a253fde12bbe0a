"""Track-to-track fusion of correlated horizontal estimates: a consistency gate, the
covariance intersection of the largest mutually consistent set, a mixture when the
inputs split into rival sets.

Every estimate is a horizontal position ``mean`` (2,) [m, ENU] with covariance ``cov``
(2, 2) [m^2]. The inputs of one firefighter all dead-reckon the same foot-INS strides,
so their errors are correlated by an unknown amount: covariance intersection
(Julier and Uhlmann 1997) is the fusion that stays consistent whatever the
cross-correlation, ``P^-1 = sum_i w_i P_i^-1``, ``P^-1 x = sum_i w_i P_i^-1 x_i`` with
``w`` on the simplex; the weights chosen here minimise ``det P`` (the D-optimal
choice: a concave problem in ``w``, solved by the multiplicative fixed point of
D-optimal design, which keeps ``w`` on the simplex and never decreases ``det P^-1``).
"""
from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from firenav_framework.integrity import gaussian_protection_radius

__all__ = ["covariance_intersection", "gate_matrix", "chi2_2dof_quantile",
           "Hypothesis", "consistent_hypotheses", "mixture"]


def chi2_2dof_quantile(p: float) -> float:
    """The ``p`` quantile of the chi-square distribution with 2 degrees of freedom."""
    return -2.0 * math.log1p(-p)


def covariance_intersection(covs: np.ndarray, means: np.ndarray, *, iterations: int = 100,
                            tol: float = 1e-10) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Covariance intersection of ``n`` estimates, weights minimising ``det P``.

    ``covs`` (n, 2, 2) [m^2], ``means`` (n, 2) [m]. Returns ``(mean (2,), cov (2, 2),
    weights (n,))``. One estimate is returned as it is.
    """
    covs = np.asarray(covs, float)
    means = np.asarray(means, float)
    n = len(covs)
    if n == 1:
        return means[0].copy(), covs[0].copy(), np.ones(1)
    info = np.linalg.inv(covs)                       # (n, 2, 2)
    w = np.full(n, 1.0 / n)
    for _ in range(iterations):
        fused_info = np.einsum("i,ijk->jk", w, info)
        p = np.linalg.inv(fused_info)
        # D-optimal multiplicative update: w_i <- w_i tr(I_i P) / 2 (sums to 1)
        new = w * np.einsum("ijk,kj->i", info, p) / 2.0
        new = np.maximum(new, 0.0)
        new /= new.sum()
        done = float(np.max(np.abs(new - w))) < tol
        w = new
        if done:
            break
    fused_info = np.einsum("i,ijk->jk", w, info)
    p = np.linalg.inv(fused_info)
    p = 0.5 * (p + p.T)
    mean = p @ np.einsum("i,ijk,ik->j", w, info, means)
    return mean, p, w


def gate_matrix(means: np.ndarray, covs: np.ndarray, floors: list[int | None],
                threshold: float) -> np.ndarray:
    """(n, n) bool: are estimates i and j consistent?

    Consistent: on the same floor (or one floor unknown) and the Mahalanobis distance of
    the difference with both covariances, ``d^T (P_i + P_j)^-1 d``, at most ``threshold``
    (a chi-square quantile, 2 degrees of freedom). ``P_i + P_j`` ignores the positive
    correlation of the inputs, so the gate errs towards keeping an input.
    """
    n = len(means)
    ok = np.ones((n, n), bool)
    for i, j in itertools.combinations(range(n), 2):
        d = means[i] - means[j]
        s = covs[i] + covs[j]
        try:
            m2 = float(d @ np.linalg.solve(s, d))
        except np.linalg.LinAlgError:
            m2 = math.inf
        same_floor = floors[i] is None or floors[j] is None or floors[i] == floors[j]
        ok[i, j] = ok[j, i] = same_floor and m2 <= threshold
    return ok


@dataclass(frozen=True)
class Hypothesis:
    """The fusion of one mutually consistent set of inputs (their indices ``members``)."""

    members: tuple[int, ...]
    mean: np.ndarray
    cov: np.ndarray
    weights: np.ndarray


def consistent_hypotheses(means: np.ndarray, covs: np.ndarray, floors: list[int | None],
                          threshold: float) -> list[Hypothesis]:
    """The largest sets of pairwise consistent inputs, each fused by covariance intersection.

    Sets of the largest size are found by enumeration (a firefighter has a handful of
    inputs); several sets of that size whose fusions are consistent with each other are
    the same answer told with different company, and only the most informative (least
    ``det P``) of them is kept; what remains are rival hypotheses (mutually inconsistent),
    most informative first.
    """
    n = len(means)
    ok = gate_matrix(means, covs, floors, threshold)
    best: list[tuple[int, ...]] = []
    for size in range(n, 0, -1):
        best = [c for c in itertools.combinations(range(n), size)
                if all(ok[i, j] for i, j in itertools.combinations(c, 2))]
        if best:
            break
    hyps = []
    for members in best:
        idx = list(members)
        mean, cov, w = covariance_intersection(covs[idx], means[idx])
        hyps.append(Hypothesis(members, mean, cov, w))
    hyps.sort(key=lambda h: float(np.linalg.det(h.cov)))
    kept: list[Hypothesis] = []
    for h in hyps:
        if not any(_agree(h, k, threshold) for k in kept):
            kept.append(h)
    return kept


def _agree(a: Hypothesis, b: Hypothesis, threshold: float) -> bool:
    d = a.mean - b.mean
    try:
        return float(d @ np.linalg.solve(a.cov + b.cov, d)) <= threshold
    except np.linalg.LinAlgError:
        return False


def mixture(hyps: list[Hypothesis], containment: float) -> tuple[np.ndarray, np.ndarray, float]:
    """Equal-weight mixture of rival hypotheses: ``(mean, cov, protection radius)``.

    The covariance is the mixture's (each component's plus its offset from the mean);
    the radius is ``max_i (|mean_i - mean| + r_i)`` with ``r_i`` the Gaussian radius of
    component i: that disc holds every component's own ``containment`` disc, so it holds
    ``containment`` of the mixture whichever hypothesis is true.
    """
    means = np.array([h.mean for h in hyps])
    mean = means.mean(axis=0)
    cov = np.zeros((2, 2))
    radius = 0.0
    for h in hyps:
        d = h.mean - mean
        cov += (h.cov + np.outer(d, d)) / len(hyps)
        radius = max(radius, float(np.hypot(*d)) + gaussian_protection_radius(h.cov, containment))
    return mean, cov, radius
