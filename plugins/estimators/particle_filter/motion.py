"""Time update: move particles by an odometry increment, then add noise (§IV-E, §V-B).

Each particle's displacement is the odometry increment rotated into the building by
its frame rotation and scaled by its step scale. The paper then adds Gaussian noise
of 0.12 m per axis to the position and 2 deg per traversed metre to the yaw at every
update of a 2 Hz filter. Our increments need not come at 2 Hz (the INS emits one per
stance), so an increment lasting ``dt`` seconds and covering ``L`` metres is treated
as ``n = dt / period`` updates of the paper's filter with the motion spread evenly:

    var(position, per axis) = n * sigma_p^2
    var(yaw)                = n * (sigma_h * L / n)^2 = (sigma_h * L)^2 / n

which equals the paper's noise exactly at its own rate and the same accumulated
noise at any other rate. Particles with a ``yaw_rate`` (an uncalibrated yaw gyro
bias turns the INS frame steadily) also turn their frame rotation by it. An
increment with ``dt = 0`` (the estimator passes the time spent moving: see its
``noise_while_still``) adds no noise.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from firenav_framework.capabilities.particles import Particles
from firenav_framework.geometry import wrap_angles

__all__ = ["MotionNoise", "propagate"]


@dataclass(frozen=True)
class MotionNoise:
    """Process noise of the time update (paper defaults, §V-B)."""

    position_sigma_m: float = 0.12
    period_s: float = 0.5
    heading_sigma_rad_per_m: float = float(np.deg2rad(2.0))

    def variances(self, dt: float, distance: float) -> tuple[float, float]:
        """(position variance per axis [m^2], yaw variance [rad^2]) for one increment of
        ``dt`` seconds of motion [s] covering ``distance`` [m]; none when ``dt <= 0``."""
        if dt <= 0:
            return 0.0, 0.0
        n = dt / self.period_s
        return n * self.position_sigma_m ** 2, (self.heading_sigma_rad_per_m * distance) ** 2 / n


def propagate(p: Particles, delta_xy: np.ndarray, dt: float, noise: MotionNoise,
              rng: np.random.Generator, drift_s: float = 0.0) -> None:
    """Move every particle of ``p`` in place by the INS-frame increment ``delta_xy`` (2,) [m].

    ``dt`` [s] is the time the noise accumulates over; ``drift_s`` [s] the whole
    duration of the increment, over which each frame rotation turns at its
    ``yaw_rate`` (the increment is rotated by the rotation at its middle).
    """
    drifting = drift_s > 0 and np.any(p.yaw_rate)
    if drifting:
        p.yaw = p.yaw + 0.5 * drift_s * p.yaw_rate
    c, s = np.cos(p.yaw), np.sin(p.yaw)
    dx, dy = float(delta_xy[0]), float(delta_xy[1])
    n = len(p)
    var_pos, var_yaw = noise.variances(dt, float(np.hypot(dx, dy)))
    p.xy[:, 0] += p.scale * (c * dx - s * dy)
    p.xy[:, 1] += p.scale * (s * dx + c * dy)
    if drifting:
        p.yaw = wrap_angles(p.yaw + 0.5 * drift_s * p.yaw_rate)
    if var_pos > 0:
        p.xy[:, 0] += rng.standard_normal(n) * np.sqrt(var_pos)
        p.xy[:, 1] += rng.standard_normal(n) * np.sqrt(var_pos)
    if var_yaw > 0:
        p.yaw = wrap_angles(p.yaw + rng.standard_normal(n) * np.sqrt(var_yaw))
