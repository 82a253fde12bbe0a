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
           "Hypothesis", "consistent_hypotheses", "mixture", "leave_one_out"]


def chi2_2dof_quantile(p: float) -> float:
    """The ``p`` quantile of the chi-square distribution with 2 degrees of freedom."""
    return -2.0 * math.log1p(-p)


def _sym(c: np.ndarray) -> tuple[float, float, float]:
    """``(a, b, d)`` of a symmetric 2x2 matrix ``[[a, b], [b, d]]``."""
    return float(c[0, 0]), 0.5 * float(c[0, 1] + c[1, 0]), float(c[1, 1])


def _inv(a: float, b: float, d: float) -> tuple[float, float, float]:
    det = a * d - b * b
    return d / det, -b / det, a / det


def covariance_intersection(covs: np.ndarray, means: np.ndarray, *, iterations: int = 200,
                            tol: float = 1e-7) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Covariance intersection of ``n`` estimates, weights minimising ``det P``.

    ``covs`` (n, 2, 2) [m^2], ``means`` (n, 2) [m]. Returns ``(mean (2,), cov (2, 2),
    weights (n,))``. One estimate is returned as it is; for two the weight is exact
    (``det P^-1`` is a quadratic in it); for more, the multiplicative fixed point (2x2
    algebra in floats: this runs for every firefighter at every stride).
    """
    n = len(covs)
    if n == 1:
        return np.asarray(means[0], float).copy(), np.asarray(covs[0], float).copy(), np.ones(1)
    info = [_inv(*_sym(c)) for c in covs]
    if n == 2:
        (a0, b0, d0), (a1, b1, d1) = info
        # det(I1 + w (I0 - I1)) = det I1 + w c1 + w^2 det(I0 - I1)
        ya, yb, yd = a0 - a1, b0 - b1, d0 - d1
        c1 = a1 * yd + d1 * ya - 2.0 * b1 * yb
        c2 = ya * yd - yb * yb
        cands = [0.0, 1.0]
        if c2 < 0:
            cands.append(min(1.0, max(0.0, -c1 / (2.0 * c2))))
        f = [c1 * w + c2 * w * w for w in cands]
        w0 = cands[int(np.argmax(f))]
        w = [w0, 1.0 - w0]
    else:
        w = [1.0 / n] * n
        for _ in range(iterations):
            fa = sum(wi * i[0] for wi, i in zip(w, info))
            fb = sum(wi * i[1] for wi, i in zip(w, info))
            fd = sum(wi * i[2] for wi, i in zip(w, info))
            pa, pb, pd = _inv(fa, fb, fd)
            # D-optimal multiplicative update: w_i <- w_i tr(I_i P) / 2 (sums to 1)
            new = [wi * (i[0] * pa + 2.0 * i[1] * pb + i[2] * pd) / 2.0
                   for wi, i in zip(w, info)]
            total = sum(new)
            new = [x / total for x in new]
            done = max(abs(x - y) for x, y in zip(new, w)) < tol
            w = new
            if done:
                break
    fa = sum(wi * i[0] for wi, i in zip(w, info))
    fb = sum(wi * i[1] for wi, i in zip(w, info))
    fd = sum(wi * i[2] for wi, i in zip(w, info))
    pa, pb, pd = _inv(fa, fb, fd)
    ya = sum(wi * (i[0] * m[0] + i[1] * m[1]) for wi, i, m in zip(w, info, means))
    yb = sum(wi * (i[1] * m[0] + i[2] * m[1]) for wi, i, m in zip(w, info, means))
    mean = np.array([pa * ya + pb * yb, pb * ya + pd * yb])
    return mean, np.array([[pa, pb], [pb, pd]]), np.array(w)


def _mahalanobis2(dx: float, dy: float, a: float, b: float, d: float) -> float:
    """``[dx dy] S^-1 [dx dy]^T`` for ``S = [[a, b], [b, d]]``; inf if S is singular."""
    det = a * d - b * b
    if not det > 0:
        return math.inf
    return (d * dx * dx - 2.0 * b * dx * dy + a * dy * dy) / det


def gate_matrix(means: np.ndarray, covs: np.ndarray, floors: list[int | None],
                threshold: float) -> np.ndarray:
    """(n, n) bool: are estimates i and j consistent?

    Consistent: on the same or adjacent floors (or one floor unknown) and the
    Mahalanobis distance of the difference with both covariances, ``d^T (P_i + P_j)^-1 d``,
    at most ``threshold`` (a chi-square quantile, 2 degrees of freedom). ``P_i + P_j``
    ignores the positive correlation of the inputs, so the gate errs towards keeping an
    input. Adjacent floors are the stairs: each method switches floor at its own moment
    of a flight (its own height evidence), so a floor apart there says nothing about the
    horizontal position; the floor itself is the vote's.
    """
    n = len(means)
    ok = np.ones((n, n), bool)
    sym = [_sym(c) for c in covs]
    for i, j in itertools.combinations(range(n), 2):
        m2 = _mahalanobis2(float(means[i][0] - means[j][0]), float(means[i][1] - means[j][1]),
                           sym[i][0] + sym[j][0], sym[i][1] + sym[j][1], sym[i][2] + sym[j][2])
        near_floor = floors[i] is None or floors[j] is None or abs(floors[i] - floors[j]) <= 1
        ok[i, j] = ok[j, i] = near_floor and m2 <= threshold
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
    hyps.sort(key=lambda h: float(h.cov[0, 0] * h.cov[1, 1] - h.cov[0, 1] ** 2))
    kept: list[Hypothesis] = []
    for h in hyps:
        if not any(_agree(h, k, threshold) for k in kept):
            kept.append(h)
    return kept


def _agree(a: Hypothesis, b: Hypothesis, threshold: float) -> bool:
    s = a.cov + b.cov
    return _mahalanobis2(float(a.mean[0] - b.mean[0]), float(a.mean[1] - b.mean[1]),
                         float(s[0, 0]), float(s[0, 1]), float(s[1, 1])) <= threshold


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


def leave_one_out(h: Hypothesis, means: np.ndarray, covs: np.ndarray, k: int
                  ) -> tuple[np.ndarray, np.ndarray] | None:
    """The fusion of hypothesis ``h`` without its member ``k`` (an index into ``means``
    (n, 2) [m] and ``covs`` (n, 2, 2) [m^2]): ``(mean, cov)`` with the remaining CI
    weights renormalised, or None when the others carry (almost) no weight."""
    pos = h.members.index(k)
    rest = 1.0 - float(h.weights[pos])
    if rest < 1e-6:
        return None
    info = np.zeros((2, 2))
    y = np.zeros(2)
    for j, w in zip(h.members, h.weights):
        if j != k and w > 0:
            inv = np.linalg.inv(covs[j])
            info += w * inv
            y += w * inv @ means[j]
    cov = np.linalg.inv(info / rest)
    return cov @ (y / rest), cov
