"""How far the particle filter's pose may be off, and when its motion contradicts the plan.

* :func:`cloud_protection_radius`: the horizontal error bound [m] of the weighted cloud
  about the reported mean (:func:`firenav_framework.integrity.sample_protection_radius`,
  so a second cluster counts in full), each particle blurred by a Gaussian kernel of
  ``kernel_m`` per axis (the cloud is a finite sample of a posterior that also carries
  the plan's own inaccuracy). Weight on another floor than the reported one beyond
  ``1 - containment`` gives ``inf``: the floor itself is in doubt.
* :class:`ContradictionMonitor`: the *retained fraction* of an update is the prior
  weight of the cloud the constraints leave standing relative to the best particle,
  ``sum_i w_i exp(l_i - max l)`` (1: every particle as likely as the best; 0: the walls
  removed nearly all the weight). Smoothed over updates, a fraction below ``floor``
  means the motion contradicts the plan where the filter believes it is (a door drawn
  as a wall, a walled-up door, furniture the walk goes round): the filter reports it
  once per episode with the place and widens (:func:`roughen`) instead of holding on;
  the pose stays untrusted for ``hold_s`` seconds after the last contradiction.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from firenav_framework.capabilities.particles import Particles
from firenav_framework.geometry import wrap_angles
from firenav_framework.integrity import sample_protection_radius

__all__ = ["cloud_protection_radius", "retained_fraction", "ContradictionMonitor", "roughen"]


def cloud_protection_radius(p: Particles, centre_xy: np.ndarray, floor: int,
                            containment: float, kernel_m: float) -> float:
    """Protection radius [m] of cloud ``p`` about ``centre_xy`` (2,) on ``floor``."""
    w = p.weights
    same = p.floor == floor
    if float(np.sum(w[~same])) > 1.0 - containment:
        return math.inf
    r = sample_protection_radius(p.xy[same], w[same], centre_xy, containment)
    return math.hypot(r, kernel_m * math.sqrt(-2.0 * math.log1p(-containment)))


def retained_fraction(logw: np.ndarray, loglik: np.ndarray) -> float:
    """Share of the normalised prior weight ``exp(logw)`` kept by log-likelihoods
    ``loglik`` relative to the most likely particle (1 when none is better than another)."""
    top = float(np.max(loglik))
    if not math.isfinite(top):
        return 0.0
    with np.errstate(over="ignore", invalid="ignore"):
        return float(np.sum(np.exp(logw + (loglik - top))))


@dataclass
class ContradictionMonitor:
    """Per firefighter: is the motion contradicting the plan (see the module)?"""

    floor: float = 0.25
    smoothing: float = 0.3
    hold_s: float = 10.0
    level: float = 1.0
    active: bool = False
    last_contradiction_t: float = -math.inf

    def update(self, t: float, retained: float) -> bool:
        """Feed one update's retained fraction; True when a contradiction episode starts."""
        self.level += self.smoothing * (min(max(retained, 0.0), 1.0) - self.level)
        if self.level < self.floor:
            self.last_contradiction_t = t
            if not self.active:
                self.active = True
                return True
        elif self.active and t - self.last_contradiction_t > self.hold_s:
            self.active = False
        return False

    @property
    def contradicted(self) -> bool:
        """The pose must not be trusted (contradiction now or within ``hold_s``)."""
        return self.active

    def widening(self) -> bool:
        """Whether the cloud should be widened this update (smoothed level below floor)."""
        return self.level < self.floor


def roughen(p: Particles, sigma_m: float, sigma_rad: float, rng: np.random.Generator) -> None:
    """Widen the cloud in place: Gaussian jitter of ``sigma_m`` per axis on position and
    ``sigma_rad`` on the frame rotation (the filter falls back towards its odometry with a
    growing uncertainty instead of holding on to where the plan put it)."""
    n = len(p)
    if sigma_m > 0:
        p.xy += rng.standard_normal((n, 2)) * sigma_m
    if sigma_rad > 0:
        p.yaw = wrap_angles(p.yaw + rng.standard_normal(n) * sigma_rad)
