"""Which door a tag is on, when the track cannot say for sure.

The paper associates a new tag with the door of least distance cost from the
dead-reckoned position ("RFID and Database") and then corrects the agent to it. With an
uncalibrated INS the estimate is metres off at the second-floor doors, which are
1.6-3 m apart: the least-cost door is then often the wrong one, and a correction to it
teleports the track there (and every later reader of that tag with it).

Here the cost is turned into a probability per candidate site (a Gaussian likelihood
with the estimate's covariance plus the read's own spread, the same for every site, so
only the Mahalanobis distances matter). A deployment whose best site has at least
``confidence`` is *resolved*; otherwise the tag is *tentative*: it is bound to its best
site for now, the position update goes to that site with a noise that covers the other
candidates (their second moment about it: the covariance shows the doubt instead of
hiding it, and no update goes part of the way to a wrong door), and every
later read of the tag, by any agent, multiplies in that agent's likelihood until one site
reaches ``confidence`` (the tag is then re-associated to it if that is another site).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Candidates", "site_weights", "spread_about_best"]

#: Candidates below this share of the weight are dropped.
MIN_WEIGHT = 1e-3


@dataclass
class Candidates:
    """The sites a tentative tag may be on: ``sites`` (indices into the tag database's
    sites) and their probabilities ``weights`` (sum 1)."""

    sites: np.ndarray
    weights: np.ndarray

    def best(self) -> tuple[int, float]:
        """(site index, probability) of the most probable candidate."""
        k = int(np.argmax(self.weights))
        return int(self.sites[k]), float(self.weights[k])

    def combine(self, costs: np.ndarray) -> Candidates:
        """The candidates after one more read with squared Mahalanobis distances ``costs``
        (over all sites of the database; inf: impossible). A read that fits none of them
        leaves them as they were."""
        c = costs[self.sites]
        like = np.exp(-0.5 * (c - np.min(c))) if np.isfinite(c).any() else np.zeros(len(c))
        w = self.weights * like
        if not w.sum() > 0:
            return self
        return _pruned(self.sites, w)


def site_weights(costs: np.ndarray, free: np.ndarray) -> Candidates | None:
    """Probabilities of the free sites (bool mask ``free``) from their squared Mahalanobis
    distances ``costs`` (inf: not on the floor). None when no free site has a finite cost."""
    c = np.where(free, costs, np.inf)
    if not np.isfinite(c).any():
        return None
    w = np.exp(-0.5 * (c - np.min(c)))
    idx = np.flatnonzero(w > 0)
    return _pruned(idx, w[idx])


def spread_about_best(positions: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The most probable candidate's position (3,) [m] and the horizontal second moment
    (2, 2) [m^2] of the candidates' positions ``positions`` (K, 3) about it, weighted by
    their probabilities ``weights`` (K,): the update goes to the best site, no part of
    the way to a wrong one, with a noise that covers the others."""
    w = weights / weights.sum()
    best = positions[int(np.argmax(w))]
    d = positions[:, :2] - best[:2]
    return best, (w[:, None] * d).T @ d


def _pruned(sites: np.ndarray, w: np.ndarray) -> Candidates:
    w = w / w.sum()
    keep = w >= MIN_WEIGHT
    return Candidates(np.asarray(sites)[keep], w[keep] / w[keep].sum())
