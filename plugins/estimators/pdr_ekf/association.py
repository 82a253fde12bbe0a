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

from dataclasses import dataclass, field

import numpy as np

__all__ = ["Candidates", "site_weights", "spread_about_best"]

#: Candidates below this share of the weight are dropped.
MIN_WEIGHT = 1e-3


@dataclass
class Candidates:
    """The sites a tentative tag may be on: ``sites`` (indices into the tag database's
    sites), their probabilities at the deployment ``prior`` (sum 1), who deployed it,
    and the evidence of every read since: per agent, the summed log-likelihood of each
    candidate (kept per agent so that a reset of one firefighter forgets its part)."""

    sites: np.ndarray
    prior: np.ndarray
    deployer: str = ""
    evidence: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def weights(self) -> np.ndarray:
        """Probabilities (sum 1) of the candidates after all the reads."""
        log_w = np.log(self.prior) + sum(self.evidence.values(), np.zeros(len(self.sites)))
        if not np.isfinite(log_w).any():
            return self.prior
        w = np.exp(log_w - np.max(log_w))
        return w / w.sum()

    def best(self) -> tuple[int, float]:
        """(site index, probability) of the most probable candidate."""
        w = self.weights
        k = int(np.argmax(w))
        return int(self.sites[k]), float(w[k])

    def add(self, agent: str, costs: np.ndarray) -> None:
        """One more read by ``agent`` with squared Mahalanobis distances ``costs`` (over
        all sites of the database; inf: impossible). A read that fits none of the
        candidates teaches nothing."""
        c = costs[self.sites]
        if not np.isfinite(c).any():
            return
        log_like = -0.5 * (c - np.min(c))
        self.evidence[agent] = self.evidence.get(agent, np.zeros(len(self.sites))) + log_like

    def forget(self, agent: str) -> None:
        """Drop what ``agent``'s reads said."""
        self.evidence.pop(agent, None)


def site_weights(costs: np.ndarray, free: np.ndarray, deployer: str = "") -> Candidates | None:
    """The free sites (bool mask ``free``) as candidates with probabilities from their
    squared Mahalanobis distances ``costs`` (inf: not on the floor); those under
    ``MIN_WEIGHT`` are dropped. None when no free site has a finite cost."""
    c = np.where(free, costs, np.inf)
    if not np.isfinite(c).any():
        return None
    w = np.exp(-0.5 * (c - np.min(c)))
    w = w / w.sum()
    idx = np.flatnonzero(w >= MIN_WEIGHT)
    return Candidates(idx, w[idx] / w[idx].sum(), deployer)


def spread_about_best(positions: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The most probable candidate's position (3,) [m] and the horizontal second moment
    (2, 2) [m^2] of the candidates' positions ``positions`` (K, 3) about it, weighted by
    their probabilities ``weights`` (K,): the update goes to the best site, no part of
    the way to a wrong one, with a noise that covers the others."""
    w = weights / weights.sum()
    best = positions[int(np.argmax(w))]
    d = positions[:, :2] - best[:2]
    return best, (w[:, None] * d).T @ d
