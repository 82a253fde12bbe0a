"""The absolute pose's covariance: the filter's own plus the errors it does not model.

The filter's covariance of the absolute pose (``Step.cov_abs``) grows with white sensor
noise only: without bias states its heading sigma stays below a degree over minutes,
while a worn unit's heading drifts at a rate of its own (0.02-0.31 deg/s on the real
indoor walks, ``docs/foot-ins.md``). A heading error turns every later step, so the
position error it causes grows with the distance walked. :class:`PoseUncertainty`
carries those errors in the INS frame, propagated step by step:

* the drift rate, one constant per mission with sigma ``drift_rate_sigma`` (the poses'
  own spread; by default the odometry's ``yaw_drift_rate_sigma`` of
  ``steps.UnmodelledErrors``, published on every message, which it leaves alone), adds
  ``rate * duration`` to the heading (so the heading variance is ``(sigma t)^2``);
* fast gaits (:class:`FastGaitErrors`) add a second lasting drift rate that acts only as
  fast as the step goes above a walking speed (impacts of 5-8 g: gyro g-sensitivity and
  vibration rectification, the accelerometer and gyro saturating): heading is lost by
  ``rate * max(0, speed - speed_from) * duration``;
* a heading error ``e`` turns every later step ``delta`` by ``e``. For the two drift
  rates this is followed without linearising: after ten minutes at 0.17 deg/s the
  heading sigma is 100 deg, where ``(-delta_y, delta_x) e`` (a thin ellipse across the
  track) no longer describes the error, which spreads along the track as well. The
  rates are carried as Gauss-Hermite nodes (``RATE_NODES`` x ``FAST_NODES``): each node's
  heading error and the position error of the steps turned by it, and the covariance is
  their weighted second moment about the estimate;
* the scale error, one constant per mission with sigma ``scale_sigma``, lengthens every
  step's horizontal displacement alike (the ZUPTs cannot see it: a simulated unit
  measures 98-99 % of the distance on every run), and each step's own turn-rate and
  step-length errors (``steps.UnmodelledErrors``, as the odometry increments carry them)
  are a linear covariance over (x, y, z [m], heading [rad], scale [-]): small, where the
  linear model holds; the two parts are taken as independent;
* a step whose swing ran longer than ``long_swing`` (zero-velocity updates missed:
  seconds of strapdown integration unaided) has a horizontal error growing with the
  excess, in any direction (:class:`FastGaitErrors`); a step the INS cannot vouch for
  has a horizontal error of its whole length on either axis: one faster than
  ``max_speed`` (no one on foot covers ground that fast: the INS has lost its stances
  and integrates unaided), or one with more than ``max_clipped`` of its samples
  saturated (``clipping``: the sensor read less than the foot did, by an amount unknown);
* without a fix the horizontal uncertainty does not shrink (``hold_peak``): the
  drift-rate nodes make the position error a fixed function of one rate, so on the way
  back along an out-and-back path their offsets cancel and the covariance shrinks to
  the scale and floor terms alone, while the error of a real unit, whose drift is not
  exactly one rate from the start, does not cancel; so the published horizontal
  covariance is raised by a circle to the largest horizontal variance it has had.

:meth:`PoseUncertainty.step` returns the pose covariance (4, 4) over (x, y, z, heading):
the filter's ``cov_abs`` plus the unmodelled part, the two taken as independent, plus a
horizontal floor ``position_sigma``: the point the INS tracks (the IMU) is not the point
the truth is of (a footprint, a marker, the wearer), a lever arm of centimetres that
turns with the foot. The ``pose`` and ``state`` outputs publish it with a protection
radius from it.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .steps import Step, UnmodelledErrors

__all__ = ["FastGaitErrors", "PoseUncertainty"]

_SCALE = 4   # index of the step-length scale error in the linear covariance
#: Gauss-Hermite nodes of the lasting drift rate and of the fast-gait one.
RATE_NODES = 15
FAST_NODES = 7


def _gauss_hermite(sigma: float, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and weights (summing to 1) of a zero-mean normal of spread ``sigma``."""
    if sigma == 0.0:
        return np.zeros(1), np.ones(1)
    x, w = np.polynomial.hermite_e.hermegauss(n)
    return sigma * x, w / w.sum()


@dataclass(frozen=True)
class FastGaitErrors:
    """Errors of steps faster or longer than walking's (SI units, see the module)."""

    speed_from: float = 2.0          # [m/s] step speed above which the fast-gait drift acts
    speed_drift_sigma: float = 0.0   # [rad/s per m/s] spread of that drift rate
    long_swing: float = 2.0          # [s] steps lasting longer missed zero-velocity updates
    long_swing_sigma: float = 0.0    # [1/s] relative horizontal error per second beyond it
    max_speed: float | None = None   # [m/s] faster steps are lost: error of their length
    max_clipped: float | None = None  # [-] steps with a larger share saturated are lost

    def lost_variance(self, step: Step, duration: float, clipped: float = 0.0) -> float:
        """Variance [m^2] per horizontal axis of a lost step, faster than ``max_speed`` or
        with a share ``clipped`` of its samples saturated above ``max_clipped``: its
        squared length (0 for a step the INS can vouch for)."""
        length2 = float(step.delta[:2] @ step.delta[:2])
        too_fast = self.max_speed is not None and length2 > (self.max_speed * duration) ** 2
        too_clipped = self.max_clipped is not None and clipped > self.max_clipped
        return length2 if too_fast or too_clipped else 0.0

    def excess_speed(self, step: Step, duration: float) -> float:
        """How far [m/s] the step's horizontal speed lies above ``speed_from``."""
        if duration <= 0.0:
            return 0.0
        return max(0.0, float(np.hypot(step.delta[0], step.delta[1])) / duration
                   - self.speed_from)

    def long_swing_variance(self, step: Step, duration: float) -> float:
        """Variance [m^2] per horizontal axis of a step lasting ``duration`` [s]."""
        excess = max(0.0, duration - self.long_swing)
        return (self.long_swing_sigma * excess) ** 2 * float(step.delta[:2] @ step.delta[:2])


class PoseUncertainty:
    """Unmodelled errors accumulated into one IMU's absolute pose (see the module)."""

    def __init__(self, errors: UnmodelledErrors, scale_sigma: float,
                 position_sigma: float, fast: FastGaitErrors | None = None,
                 drift_rate_sigma: float | None = None, hold_peak: bool = False) -> None:
        """``errors``: the odometry's (step-to-step parts and the lasting drift rate's
        spread); ``scale_sigma`` [-]: of the step-length scale; ``position_sigma`` [m]:
        the horizontal floor; ``fast``: the fast gaits' errors (default: none);
        ``drift_rate_sigma`` [rad/s]: the lasting drift rate's spread the poses count
        (default: the odometry's ``errors.yaw_drift_rate_sigma``); ``hold_peak``: the
        horizontal covariance never falls below the largest horizontal variance so far."""
        self.errors = errors
        self.fast = fast or FastGaitErrors()
        self.cov = np.zeros((5, 5))
        self.cov[_SCALE, _SCALE] = scale_sigma ** 2
        if drift_rate_sigma is None:
            drift_rate_sigma = errors.yaw_drift_rate_sigma
        rate, w_rate = _gauss_hermite(drift_rate_sigma, RATE_NODES)
        quick, w_quick = _gauss_hermite(self.fast.speed_drift_sigma, FAST_NODES)
        self.rate = np.repeat(rate, len(quick))          # [rad/s] per node
        self.quick = np.tile(quick, len(rate))           # [rad/s per m/s] per node
        self.weight = np.outer(w_rate, w_quick).ravel()
        self.heading = np.zeros(len(self.weight))        # [rad] each node's heading error
        self.offset = np.zeros((len(self.weight), 2))    # [m] each node's position error
        self.floor = np.diag([position_sigma ** 2, position_sigma ** 2, 0.0, 0.0])
        self.last = self.floor.copy()
        self.hold_peak = hold_peak
        self.peak = 0.0                                  # [m^2] largest horizontal variance

    def step(self, step: Step, clipped: float = 0.0) -> np.ndarray:
        """Propagate over one step, ``clipped`` [0, 1] the share of its samples saturated
        (``clipping.ClipLog``); the pose covariance (4, 4) at its end, INS frame."""
        duration = max(step.t - step.t_start, 0.0)
        dx, dy = float(step.delta[0]), float(step.delta[1])
        f = np.eye(5)
        f[0, 3], f[1, 3] = -dy, dx
        f[0, _SCALE], f[1, _SCALE] = dx, dy
        self.cov = f @ self.cov @ f.T
        self.cov[:4, :4] += self.errors.inflate(np.zeros((4, 4)), step.delta, duration)
        swing = (self.fast.long_swing_variance(step, duration)
                 + self.fast.lost_variance(step, duration, clipped))
        self.cov[0, 0] += swing
        self.cov[1, 1] += swing
        c, s = np.cos(self.heading) - 1.0, np.sin(self.heading)
        self.offset[:, 0] += c * dx - s * dy
        self.offset[:, 1] += s * dx + c * dy
        self.heading += (self.rate + self.quick * self.fast.excess_speed(step, duration)) \
            * duration
        drift = np.zeros((4, 4))
        e = np.column_stack((self.offset, self.heading))       # (nodes, x y heading)
        m = (e * self.weight[:, None]).T @ e
        drift[np.ix_([0, 1, 3], [0, 1, 3])] = m
        self.last = self.cov[:4, :4] + drift + self.floor
        if self.hold_peak:
            largest = float(np.linalg.eigvalsh((step.cov_abs + self.last)[:2, :2])[-1])
            self.peak = max(self.peak, largest)
            self.last[0, 0] += self.peak - largest
            self.last[1, 1] += self.peak - largest
        return step.cov_abs + self.last
