"""How far the particle filter's pose may be off, and when its motion contradicts the plan.

* :func:`cloud_protection_radius`: the horizontal error bound [m] of the weighted cloud
  about the reported mean (:func:`firenav_framework.integrity.sample_protection_radius`,
  so a second cluster counts in full), each particle blurred by a Gaussian kernel of
  ``kernel_m`` per axis (the cloud is a finite sample of a posterior that also carries
  the plan's own inaccuracy), the cloud's own radius taken ``scale`` times wider (a cloud
  the walls of a partly wrong plan hold is narrower than its error). Weight on another
  floor than the reported one beyond ``1 - containment`` gives ``inf``: the floor itself
  is in doubt.
* :class:`ContradictionMonitor`: the *retained fraction* of an update is the prior
  weight of the cloud the constraints leave standing relative to the best particle,
  ``sum_i w_i exp(l_i - max l)`` (1: every particle as likely as the best; 0: the walls
  removed nearly all the weight). Smoothed over updates, a fraction below ``floor``
  means the motion contradicts the plan where the filter believes it is (a door drawn
  as a wall, a walled-up door, furniture the walk goes round): the filter reports it
  once per episode with the place and widens (:func:`roughen`) instead of holding on;
  the pose stays untrusted for ``hold_s`` seconds after the last contradiction.
* :class:`JumpMonitor`: a look-alike jump needs evidence. The *reweighting shift* of an
  update is how far the reported mean moved for reasons other than the particles' own
  motion: the mean after the update minus the mean of the propagated particles under
  their prior weights (weight passing from one hypothesis to another, resampling,
  injected particles). Summed as a vector over the last ``window_s`` seconds (ordinary
  corrections of a converged cloud cancel out, a switch between look-alike rooms adds
  up), a shift longer than ``jump_m`` is a jump: reported once with both places, and the
  pose stays untrusted until the firefighter has walked ``evidence_m`` metres without
  another one.
* :class:`PlanEvidenceMonitor`: the contradiction monitor sees a plan that refutes most of
  the cloud at once; a plan that refutes a part of it at every update (a door drawn as a
  wall the walk keeps going through, a cloud in the wrong room pressed against its
  walls) adds up instead. The product of the retained fractions over the last
  ``window_m`` metres walked below ``floor`` means the motion contradicts the plan there:
  the pose is untrusted and ``map_error`` raised with the place while it lasts.
* :class:`DoubtMonitor`: a cloud the plan contradicted may have been pushed into a
  look-alike room and settle there, where the walls no longer object. After a
  contradiction (either monitor above) the pose stays untrusted until ``evidence_m``
  metres have been walked without another one; and while the pose is not trusted its
  published covariance grows by ``growth`` metres of sigma per axis for every metre
  walked since it last was (the cloud's own spread says where the plan put it, not how
  far that may be from the firefighter; the growth is of the order of an INS's drift).
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

import numpy as np

from firenav_framework.capabilities.particles import Particles
from firenav_framework.geometry import wrap_angles
from firenav_framework.integrity import sample_protection_radius

__all__ = ["cloud_protection_radius", "retained_fraction", "ContradictionMonitor", "JumpMonitor",
           "PlanEvidenceMonitor", "DoubtMonitor", "roughen"]


def cloud_protection_radius(p: Particles, centre_xy: np.ndarray, floor: int,
                            containment: float, kernel_m: float, scale: float = 1.0) -> float:
    """Protection radius [m] of cloud ``p`` about ``centre_xy`` (2,) on ``floor``, the
    cloud's own radius taken ``scale`` times wider."""
    w = p.weights
    same = p.floor == floor
    if float(np.sum(w[~same])) > 1.0 - containment:
        return math.inf
    r = sample_protection_radius(p.xy[same], w[same], centre_xy, containment)
    return math.hypot(scale * r, kernel_m * math.sqrt(-2.0 * math.log1p(-containment)))


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


@dataclass
class JumpMonitor:
    """Per firefighter: did the estimate jump between hypotheses (see the module)?"""

    jump_m: float
    evidence_m: float
    window_s: float = 5.0
    #: (time [s], shift x, shift y [m]) of the updates within the window
    recent: deque = field(default_factory=deque)
    #: metres walked since the last jump (inf: none yet)
    walked_since_m: float = math.inf

    def update(self, t: float, shift_xy: np.ndarray, walked_m: float) -> bool:
        """Feed one update's reweighting shift [m] and distance walked [m]; True when a
        jump is detected (the window restarts after it)."""
        self.walked_since_m += walked_m
        self.recent.append((t, float(shift_xy[0]), float(shift_xy[1])))
        while self.recent and self.recent[0][0] < t - self.window_s:
            self.recent.popleft()
        sx = sum(r[1] for r in self.recent)
        sy = sum(r[2] for r in self.recent)
        if math.hypot(sx, sy) > self.jump_m:
            self.recent.clear()
            self.walked_since_m = 0.0
            return True
        return False

    @property
    def awaiting_evidence(self) -> bool:
        """The pose must not be trusted: a jump less than ``evidence_m`` walked ago."""
        return self.walked_since_m < self.evidence_m


@dataclass
class PlanEvidenceMonitor:
    """Per firefighter: has the plan kept refuting the cloud over the last metres walked?"""

    floor: float
    window_m: float
    #: (distance walked until the update [m], log retained fraction) within the window
    recent: deque = field(default_factory=deque)
    walked_m: float = 0.0
    log_sum: float = 0.0

    def update(self, retained: float, walked_m: float) -> bool:
        """Feed one update's retained fraction and distance walked [m]; True while the
        product of the retained fractions over the last ``window_m`` metres is below
        ``floor``."""
        self.walked_m += max(walked_m, 0.0)
        log_r = math.log(min(max(retained, 1e-300), 1.0))
        self.recent.append((self.walked_m, log_r))
        self.log_sum += log_r
        while self.recent and self.recent[0][0] < self.walked_m - self.window_m:
            self.log_sum -= self.recent.popleft()[1]
        self.log_sum = min(self.log_sum, 0.0)
        return self.log_sum < math.log(self.floor)


@dataclass
class DoubtMonitor:
    """Per firefighter: evidence after a contradiction, and the uncertainty an untrusted
    pose accumulates (see the module)."""

    evidence_m: float
    growth: float
    #: metres walked since the last contradiction (inf: none yet)
    walked_since_contradiction_m: float = math.inf
    #: metres walked since the pose was last trusted
    walked_untrusted_m: float = 0.0

    def update(self, walked_m: float, contradicted: bool) -> None:
        """Feed one update's distance walked [m] and whether the plan contradicts the
        cloud at it."""
        self.walked_since_contradiction_m = (
            0.0 if contradicted else self.walked_since_contradiction_m + max(walked_m, 0.0))
        self.walked_untrusted_m += max(walked_m, 0.0)

    @property
    def awaiting_evidence(self) -> bool:
        """The pose must not be trusted: a contradiction less than ``evidence_m`` walked ago."""
        return self.walked_since_contradiction_m < self.evidence_m

    def published(self, trusted: bool) -> float:
        """Note whether this update's pose is trusted; the sigma [m] per axis to add to
        its published covariance (0 while trusted)."""
        if trusted:
            self.walked_untrusted_m = 0.0
        return self.growth * self.walked_untrusted_m


def roughen(p: Particles, sigma_m: float, sigma_rad: float, rng: np.random.Generator) -> None:
    """Widen the cloud in place: Gaussian jitter of ``sigma_m`` per axis on position and
    ``sigma_rad`` on the frame rotation (the filter falls back towards its odometry with a
    growing uncertainty instead of holding on to where the plan put it)."""
    n = len(p)
    if sigma_m > 0:
        p.xy += rng.standard_normal((n, 2)) * sigma_m
    if sigma_rad > 0:
        p.yaw = wrap_angles(p.yaw + rng.standard_normal(n) * sigma_rad)
