"""Resampling schemes and the paper's replacement of removed particles.

* :func:`resample_indices`: systematic (default), stratified, multinomial or residual
  resampling of normalised weights into ``n`` ancestor indices. All four are
  unbiased: the expected number of copies of particle i is ``n * w_i``. Systematic
  resampling has the lowest variance for its cost (one uniform draw).
* :func:`replace_removed`: §IV-E of the search-pattern paper — "all particles that
  cross a wall or have a weight below some design parameter epsilon are replaced at
  random by identical copies of the remaining particles". Survivors are drawn in
  proportion to their weights, and a survivor copied k times shares its weight with
  its k copies, so the weighted distribution is exactly preserved.
"""
from __future__ import annotations

from typing import Literal

import numpy as np

from firenav_framework.capabilities.particles import Particles

from .particles import normalise_log_weights

__all__ = ["RESAMPLERS", "Resampler", "resample_indices", "replace_removed"]

Resampler = Literal["systematic", "stratified", "multinomial", "residual"]
RESAMPLERS: tuple[str, ...] = ("systematic", "stratified", "multinomial", "residual")


def _from_positions(weights: np.ndarray, positions: np.ndarray) -> np.ndarray:
    cum = np.cumsum(weights)
    cum[-1] = 1.0  # guard against round-off leaving the last bin short
    return np.minimum(np.searchsorted(cum, positions, side="right"), len(weights) - 1)


def resample_indices(weights: np.ndarray, n: int, rng: np.random.Generator,
                     method: Resampler = "systematic") -> np.ndarray:
    """``n`` ancestor indices drawn from normalised ``weights`` with ``method``."""
    w = np.asarray(weights, dtype=float)
    if method == "systematic":
        return _from_positions(w, (rng.random() + np.arange(n)) / n)
    if method == "stratified":
        return _from_positions(w, (rng.random(n) + np.arange(n)) / n)
    if method == "multinomial":
        return _from_positions(w, np.sort(rng.random(n)))
    if method == "residual":
        counts = np.floor(n * w).astype(np.int64)
        idx = np.repeat(np.arange(len(w)), counts)
        rest = n - len(idx)
        if rest:
            resid = n * w - counts
            resid /= resid.sum()
            idx = np.concatenate([idx, _from_positions(resid, np.sort(rng.random(rest)))])
        return idx
    raise ValueError(f"unknown resampling method '{method}'; use one of {', '.join(RESAMPLERS)}")


def replace_removed(p: Particles, removed: np.ndarray, rng: np.random.Generator) -> int:
    """Replace particles flagged in ``removed`` (N,) bool by weighted copies of the rest.

    Works in place on normalised or unnormalised log-weights; returns how many were
    replaced (0 when none are left to copy from, leaving ``p`` untouched).
    """
    dead = np.flatnonzero(removed)
    alive = np.flatnonzero(~removed & np.isfinite(p.logw))
    if len(dead) == 0 or len(alive) == 0:
        return 0
    lw = p.logw[alive]
    w = np.exp(lw - lw.max())
    w /= w.sum()
    parents = alive[_from_positions(w, rng.random(len(dead)))]
    copies = np.bincount(parents, minlength=len(p))
    share = np.log1p(copies.astype(float))  # a survivor and its k copies split its weight
    p.put(dead, p.take(parents))
    p.logw[alive] -= share[alive]
    p.logw[dead] = p.logw[parents]
    normalise_log_weights(p.logw)
    return len(dead)
