"""The "particles" capability: how constraints plug into a particle filter.

A constraint for the ``particle_filter`` estimator subclasses
:class:`ParticleConstraint` and is attached in the pipeline under the estimator::

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

The particle state (:class:`Particles`): each particle carries (search-pattern paper §IV-E):

* ``xy`` (N, 2): horizontal position in the building's ENU frame [m];
* ``yaw`` (N,): the rotation [rad] from the odometry (INS) frame, whose yaw is
  arbitrary, into the building frame. A particle's walking direction is
  ``yaw + ins_heading - walk_offset`` (see :class:`ParticleStep`), so storing the frame
  rotation instead of the heading itself lets every particle share the INS heading
  and the IMU-to-walking-direction offset while keeping its own alignment;
* ``floor`` (N,): floor index; ``climb`` (N,): vertical travel [m] accumulated on
  stairs towards the next floor change;
* ``scale`` (N,): step-length scale applied to the odometry (1 when disabled);
* ``yaw_rate`` (N,): drift rate of the frame rotation [rad/s] — an INS whose yaw
  gyro bias was not calibrated turns its frame at a constant rate (0 when disabled);
* ``logw`` (N,): normalised log-weights (log-sum-exp = 0), logs because the
  pattern likelihood exp(-E / sigma^2) underflows linear weights.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from ..contract.constraint import Constraint
from ..geometry import wrap_angles
from ..messages import Odometry
from .odometry_history import OdometryHistory

__all__ = ["Particles", "ParticleStep", "ParticleConstraint"]


@dataclass
class Particles:
    """A weighted particle set (see the module docstring for the fields)."""

    xy: np.ndarray
    yaw: np.ndarray
    floor: np.ndarray
    climb: np.ndarray
    scale: np.ndarray
    logw: np.ndarray
    yaw_rate: np.ndarray

    @classmethod
    def create(cls, xy: np.ndarray, yaw: np.ndarray, floor: np.ndarray | int = 0,
               scale: np.ndarray | float = 1.0, yaw_rate: np.ndarray | float = 0.0
               ) -> "Particles":
        """Equally weighted particles from positions and frame rotations."""
        xy = np.array(xy, dtype=float).reshape(-1, 2)
        n = len(xy)
        return cls(xy=xy, yaw=np.array(wrap_angles(np.broadcast_to(yaw, (n,))), dtype=float),
                   floor=np.array(np.broadcast_to(floor, (n,)), dtype=np.int64),
                   climb=np.zeros(n),
                   scale=np.array(np.broadcast_to(scale, (n,)), dtype=float),
                   logw=np.full(n, -np.log(n)) if n else np.zeros(0),
                   yaw_rate=np.array(np.broadcast_to(yaw_rate, (n,)), dtype=float))

    def __len__(self) -> int:
        return len(self.logw)

    @property
    def weights(self) -> np.ndarray:
        """Linear weights (sum 1)."""
        return np.exp(self.logw)

    def copy(self) -> "Particles":
        return Particles(self.xy.copy(), self.yaw.copy(), self.floor.copy(),
                         self.climb.copy(), self.scale.copy(), self.logw.copy(),
                         self.yaw_rate.copy())

    def take(self, idx: np.ndarray) -> "Particles":
        """The particles at ``idx`` (copies; weights as they were, not renormalised)."""
        return Particles(self.xy[idx], self.yaw[idx], self.floor[idx], self.climb[idx],
                         self.scale[idx], self.logw[idx], self.yaw_rate[idx])

    def put(self, idx: np.ndarray, other: "Particles") -> None:
        """Overwrite the particles at ``idx`` with ``other`` (same length as ``idx``)."""
        self.xy[idx] = other.xy
        self.yaw[idx] = other.yaw
        self.floor[idx] = other.floor
        self.climb[idx] = other.climb
        self.scale[idx] = other.scale
        self.yaw_rate[idx] = other.yaw_rate
        self.logw[idx] = other.logw

    def effective_sample_size(self) -> float:
        """1 / sum(w^2) for the normalised weights."""
        w = self.weights
        return float(1.0 / np.sum(w * w))


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
        return wrap_angles(p.yaw + (self.ins_heading - self.walk_offset))

    def frame_yaw_for(self, walking_heading: np.ndarray) -> np.ndarray:
        """The frame rotation a particle needs to walk in ``walking_heading`` [rad] now."""
        return wrap_angles(np.asarray(walking_heading) - (self.ins_heading - self.walk_offset))


class ParticleConstraint(Constraint, capability=True):
    """Base of constraints that weight (and may replace) particle-filter particles."""

    #: metres of odometry history this constraint reads (the filter keeps at least this)
    history_m: ClassVar[float] = 0.0

    hooks = ("log_likelihood", "replacements")

    def log_likelihood(self, step: ParticleStep) -> np.ndarray | None:
        """(N,) log-weight increments for ``step.particles``, or None for no information."""
        return None

    def replacements(self, step: ParticleStep) -> Particles | None:
        """New particles to replace as many lowest-weight ones, or None."""
        return None
