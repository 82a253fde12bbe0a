"""The absolute pose's covariance: the filter's own plus the errors it does not model.

The filter's covariance of the absolute pose (``Step.cov_abs``) grows with white sensor
noise only: without bias states its heading sigma stays below a degree over minutes,
while a worn unit's heading drifts at a rate of its own (0.02-0.31 deg/s on the real
indoor walks, ``docs/foot-ins.md``). A heading error turns every later step, so the
position error it causes grows with the distance walked. :class:`PoseUncertainty`
carries those errors as a second covariance over (x, y, z [m], heading [rad], heading
drift rate [rad/s], step-length scale error [-]) in the INS frame, propagated step by
step:

* a heading error turns the step ``delta``: d(position) = (-delta_y, delta_x, 0) d(heading);
* the drift rate, one constant per mission with sigma ``yaw_drift_rate_sigma`` of
  ``steps.UnmodelledErrors`` (the odometry's, published on every message), adds
  ``rate * duration`` to the heading (so the heading variance is ``(sigma t)^2``);
* the scale error, one constant per mission with sigma ``scale_sigma``, lengthens every
  step's horizontal displacement alike (the ZUPTs cannot see it: a simulated unit
  measures 98-99 % of the distance on every run);
* each step adds the step-to-step turn-rate and step-length errors of
  ``steps.UnmodelledErrors``, as the odometry increments carry them.

:meth:`PoseUncertainty.step` returns the pose covariance (4, 4) over (x, y, z, heading):
the filter's ``cov_abs`` plus the unmodelled part, the two taken as independent, plus a
horizontal floor ``position_sigma``: the point the INS tracks (the IMU) is not the point
the truth is of (a footprint, a marker, the wearer), a lever arm of centimetres that
turns with the foot. The ``pose`` and ``state`` outputs publish it with a protection
radius from it.
"""
from __future__ import annotations

import numpy as np

from .steps import Step, UnmodelledErrors

__all__ = ["PoseUncertainty"]

_RATE = 4    # index of the heading drift rate in the unmodelled covariance
_SCALE = 5   # index of the step-length scale error


class PoseUncertainty:
    """Unmodelled errors accumulated into one IMU's absolute pose (see the module)."""

    def __init__(self, errors: UnmodelledErrors, scale_sigma: float,
                 position_sigma: float) -> None:
        """``errors``: the odometry's (step-to-step parts and the lasting drift rate's
        spread); ``scale_sigma`` [-]: of the step-length scale; ``position_sigma`` [m]:
        the horizontal floor."""
        self.errors = errors
        self.cov = np.zeros((6, 6))
        self.cov[_RATE, _RATE] = errors.yaw_drift_rate_sigma ** 2
        self.cov[_SCALE, _SCALE] = scale_sigma ** 2
        self.floor = np.diag([position_sigma ** 2, position_sigma ** 2, 0.0, 0.0])
        self.last = self.floor.copy()

    def step(self, step: Step) -> np.ndarray:
        """Propagate over one step; the pose covariance (4, 4) at its end, INS frame."""
        duration = max(step.t - step.t_start, 0.0)
        f = np.eye(6)
        f[0, 3], f[1, 3] = -step.delta[1], step.delta[0]
        f[3, _RATE] = duration
        f[0, _SCALE], f[1, _SCALE] = step.delta[0], step.delta[1]
        self.cov = f @ self.cov @ f.T
        self.cov[:4, :4] += self.errors.inflate(np.zeros((4, 4)), step.delta, duration)
        self.last = self.cov[:4, :4] + self.floor
        return step.cov_abs + self.last
