"""The "particles" capability: how constraints plug into the particle filter.

A constraint for the ``particle_filter`` estimator subclasses
:class:`ParticleConstraint` (``requires = {"particles"}``) and is attached in the
pipeline under the estimator::

    estimators:
      - id: pf
        plugin: particle_filter
        input: ins.odometry
        constraints:
          - {plugin: wall_crossing}
          - {plugin: search_pattern_icp}

Once per odometry update and agent the filter moves its particles and then calls,
for every attached constraint in order:

1. :meth:`ParticleConstraint.log_likelihood` with a :class:`ParticleStep`; the
   returned (N,) log-weight increments are added to the particles' log-weights
   (``-inf`` removes a particle; ``None`` means "no information this step");
2. after all weights are updated and removed particles replaced,
   :meth:`ParticleConstraint.replacements` may return new particles that replace
   the lowest-weight ones (the search-pattern constraint's pseudo-observation
   resampling, §IV-E).

Constraints keep per-agent state of their own and must implement ``reset(agent)``.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from firenav_framework import Constraint, Odometry

from .history import OdometryHistory
from .particles import Particles, wrap_angle

__all__ = ["ParticleConstraint", "ParticleStep"]


@dataclass
class ParticleStep:
    """What a constraint sees of one time update of one firefighter's filter.

    ``before`` are the particle states before the move (a snapshot), ``particles``
    the states after it (live: weights are updated by the filter, not by
    constraints). ``odometry`` is the (possibly aggregated) increment just applied,
    ``history`` the agent's INS-frame track including it, ``walk_offset`` the
    current IMU-yaw-to-walking-direction offset [rad] and ``ins_heading`` the INS
    yaw at this time [rad]. ``building`` is the pipeline's building model.
    ``spread_m2`` is var_x + var_y of the cloud after the previous update (inf before
    the first), the filter's own measure of how converged it is.
    """

    agent: str
    t: float
    odometry: Odometry
    before: Particles
    particles: Particles
    history: OdometryHistory
    ins_heading: float
    walk_offset: float
    rng: np.random.Generator
    building: Any
    spread_m2: float = float("inf")

    def walking_heading(self, p: Particles | None = None) -> np.ndarray:
        """Walking direction of each particle in the building frame [rad]."""
        p = self.particles if p is None else p
        return wrap_angle(p.yaw + (self.ins_heading - self.walk_offset))

    def frame_yaw_for(self, walking_heading: np.ndarray) -> np.ndarray:
        """The frame rotation a particle needs to walk in ``walking_heading`` [rad] now."""
        return wrap_angle(np.asarray(walking_heading) - (self.ins_heading - self.walk_offset))


class ParticleConstraint(Constraint):
    """Base of constraints that weight (and may replace) particle-filter particles."""

    requires: ClassVar[frozenset[str]] = frozenset({"particles"})
    #: metres of odometry history this constraint reads (the filter keeps at least this)
    history_m: float = 0.0

    def log_likelihood(self, step: ParticleStep) -> np.ndarray | None:
        """(N,) log-weight increments for ``step.particles``, or None for no information."""
        return None

    def replacements(self, step: ParticleStep) -> Particles | None:
        """New particles to replace as many lowest-weight ones, or None."""
        return None
