"""From filter events to step odometry: increments, gait labels, IMU mounting yaw.

The filter writes an event in every stance (one step of the instrumented foot:
``step_settle`` after the stance onset, or at its end when shorter)
and every ``still_period`` while the foot rests. :class:`StepTracker` turns them into
:class:`Step` records: the increment since the previous event in the INS frame, its
covariance (from the filter's stochastic clone), and a gait label derived from the
foot's own motion (what the RFID EKF and the particle filter use).

Gait labels (per step):

* ``still``  — a rest event, or a "step" shorter than ``still_distance`` (shuffling);
* ``crawl``  — the foot rests far from upright (tilt of its z axis above ``crawl_tilt``):
  on the knees the shoe lies on its toe cap or upside down;
* ``stairs_up`` / ``stairs_down`` — the foot rose / sank more than ``stair_rise``;
* ``stairs_down_backward`` — sank, while moving against its toe direction;
* ``walk``  — everything else (walking or running).

The toe direction is the IMU x axis plus the mounting yaw offset estimated from
walking steps (circular mean of step direction minus foot yaw), once known.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from firenav_framework.geometry import wrap_angle

from . import eskf




@dataclass(frozen=True)
class GaitThresholds:
    """Thresholds of the gait labels (SI units)."""

    stair_rise: float = 0.10        # [m] height change of one step that makes it a stair step
    crawl_tilt: float = math.radians(60.0)   # [rad] tilt of the resting foot that means crawling
    still_distance: float = 0.05    # [m] shorter 3D steps are 'still'


@dataclass(frozen=True)
class UnmodelledErrors:
    """Errors the filter does not estimate.

    Without bias states the filter's heading variance grows only with gyro white noise
    (hundredths of a degree per step), while the heading of a real foot INS drifts at a
    rate of its own for the whole mission (a residual and vibration-rectified gyro bias);
    step lengths carry an error the ZUPTs cannot see. Downstream estimators weigh
    odometry by the increments' covariance, so it must not be optimistic:

    * ``yaw_rate_sigma`` [rad/s]: a turn-rate error independent from step to step,
      ``(sigma * duration)^2`` added to each step's heading variance;
    * ``length_sigma`` [-]: relative step-length error, along the step;
    * ``yaw_drift_rate_sigma`` [rad/s]: the spread of the heading drift rate (about the
      vertical) that lasts the mission. One constant per mission, so it is no
      step-to-step error and is not in the increments' covariance: the odometry carries
      it as ``Odometry.yaw_drift_rate_sigma`` for consumers with a drift state, and the
      INS's own poses count it (``pose_uncertainty``).
    """

    yaw_rate_sigma: float = math.radians(0.05)   # [rad/s] step-to-step turn-rate error
    length_sigma: float = 0.02                   # [-] relative step-length error
    yaw_drift_rate_sigma: float = 0.0            # [rad/s] spread of the lasting drift rate

    def inflate(self, cov: np.ndarray, delta: np.ndarray, duration: float) -> np.ndarray:
        """``cov`` (4, 4) of (dx, dy, dz, dheading) plus the step-to-step errors of one
        step ``delta`` (3,) [m] lasting ``duration`` [s]."""
        out = cov.copy()
        out[3, 3] += (self.yaw_rate_sigma * max(duration, 0.0)) ** 2
        out[:3, :3] += (self.length_sigma ** 2) * np.outer(delta, delta)  # along the step
        return out


@dataclass(frozen=True)
class Step:
    """One odometry increment of the INS (INS frame: ENU with arbitrary yaw origin)."""

    t: float                 # [s] event time (settled into the stance, or a rest tick)
    t_start: float           # [s] previous event time
    delta: np.ndarray        # (3,) [m]
    dheading: float          # [rad]
    cov: np.ndarray          # (4, 4) over (dx, dy, dz, dheading)
    position: np.ndarray     # (3,) [m] absolute, INS frame
    heading: float           # [rad] yaw of the IMU x axis, INS frame
    cov_abs: np.ndarray      # (4, 4) absolute pose covariance, INS frame
    motion: str
    tilt: float              # [rad] tilt of the foot at the event
    swing_samples: int       # samples of the swing that ended at this event
    correction: np.ndarray   # (3,) [m] position correction applied at the event


class StepTracker:
    """Per-IMU step bookkeeping: previous pose, gait labels, mounting yaw estimate."""

    #: Walking steps needed before the mounting yaw is trusted, and their minimum length.
    YAW_MIN_STEPS = 5
    YAW_MIN_LENGTH = 0.3  # [m]
    YAW_MIN_CONCENTRATION = 0.8  # mean resultant length of the step directions

    def __init__(self, gait: GaitThresholds | None = None,
                 unmodelled: UnmodelledErrors | None = None) -> None:
        self.gait = gait or GaitThresholds()
        self.unmodelled = unmodelled or UnmodelledErrors()
        self.position = np.zeros(3)
        self.heading = 0.0
        self._yaw_sum = np.zeros(2)
        self._yaw_n = 0

    @property
    def mount_yaw(self) -> float | None:
        """Walking direction minus IMU x-axis yaw [rad], once enough steps agree."""
        if self._yaw_n < self.YAW_MIN_STEPS:
            return None
        r = math.hypot(*self._yaw_sum) / self._yaw_n
        if r < self.YAW_MIN_CONCENTRATION:
            return None
        return math.atan2(self._yaw_sum[1], self._yaw_sum[0])

    @property
    def mount_yaw_steps(self) -> int:
        return self._yaw_n

    def start(self, heading: float) -> None:
        """Reset the previous pose to the alignment pose (origin, given yaw)."""
        self.position = np.zeros(3)
        self.heading = heading

    def step(self, ev: np.ndarray) -> Step:
        """Turn one event row (``eskf.E_*`` columns) into a :class:`Step`."""
        pos = ev[eskf.E_POS:eskf.E_POS + 3].copy()
        yaw = float(ev[eskf.E_YAW])
        delta = pos - self.position
        dheading = wrap_angle(yaw - self.heading)
        kind = int(ev[eskf.E_KIND])
        tilt = float(ev[eskf.E_TILT])
        mid_yaw = wrap_angle(self.heading + 0.5 * dheading)
        motion = self._label(kind, delta, tilt, mid_yaw)
        if motion == "walk" and math.hypot(delta[0], delta[1]) >= self.YAW_MIN_LENGTH:
            off = math.atan2(delta[1], delta[0]) - mid_yaw
            self._yaw_sum += (math.cos(off), math.sin(off))
            self._yaw_n += 1
        t, t_start = float(ev[eskf.E_T]), float(ev[eskf.E_T_PREV])
        step = Step(t=t, t_start=t_start, delta=delta, dheading=dheading,
                    cov=self.unmodelled.inflate(
                        ev[eskf.E_COV_INC:eskf.E_COV_INC + 16].reshape(4, 4), delta, t - t_start),
                    position=pos, heading=yaw,
                    cov_abs=ev[eskf.E_COV_ABS:eskf.E_COV_ABS + 16].reshape(4, 4).copy(),
                    motion=motion, tilt=tilt, swing_samples=int(ev[eskf.E_SWING_N]),
                    correction=ev[eskf.E_CORR:eskf.E_CORR + 3].copy())
        self.position = pos
        self.heading = yaw
        return step

    def _label(self, kind: int, delta: np.ndarray, tilt: float, mid_yaw: float) -> str:
        g = self.gait
        if kind == eskf.EVENT_STILL or float(np.linalg.norm(delta)) < g.still_distance:
            return "still"
        if tilt > g.crawl_tilt:
            return "crawl"
        if delta[2] > g.stair_rise:
            return "stairs_up"
        if delta[2] < -g.stair_rise:
            toe = mid_yaw + (self.mount_yaw or 0.0)
            along = delta[0] * math.cos(toe) + delta[1] * math.sin(toe)
            return "stairs_down_backward" if along < 0.0 else "stairs_down"
        return "walk"
