"""Door-crossing heading measurement of the RFID/MEMS paper (rfid-mems-ekf, eq. 3).

A tag sits on a door jamb (or at a stair end) whose crossing direction is known from the
plan up to 180 degrees. The heading cannot be used at the tag itself (opening a door turns
the body), so once the door is passed the MEMS walking directions of ``n_s`` strides are
averaged and::

    dtheta = theta_RFID - (1 / n_s) * sum_i theta_MEMS,i          (3)

* **180 degree ambiguity**: of the two crossing directions, ``theta_RFID`` is the one
  nearer to the MEMS walking direction corrected by the current heading perturbation
  estimate (the history of the MEMS body orientation).
* **Adaptive covariance**: when the agent turns just after the door the averaged
  direction is not the crossing direction. The variance grows with the discrepancy
  ``d = theta_RFID - (mean theta_MEMS + dtheta_hat)``::

      var = (sigma^2 + spread^2 / n_s) * exp((d / d0)^2)

  so a small discrepancy updates fully and a large one hardly at all; beyond
  ``max_discrepancy`` the update is refused (the paper: "if the RFID orientation differs
  significantly from the MEMS pedestrian heading, the latter is not updated").
  ``spread`` is the circular standard deviation of the averaged strides' directions.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from firenav_framework.geometry import wrap_angle

__all__ = ["DoorHeadingConfig", "HeadingWindow", "HeadingMeasurement", "door_heading_measurement"]


@dataclass(frozen=True)
class DoorHeadingConfig:
    """Parameters of the eq. 3 measurement (the paper gives no numbers for these)."""

    strides: int = 3                              # n_s: strides averaged
    clear_distance: float = 1.0                   # [m] walked past the tag before averaging
    sigma: float = math.radians(5.0)              # [rad] door direction vs. walking direction
    discrepancy_scale: float = math.radians(15.0)  # [rad] d0 of the covariance adaptation
    max_discrepancy: float = math.radians(45.0)    # [rad] larger: no update


@dataclass
class HeadingWindow:
    """Strides collected after passing a tag site whose crossing heading is ``heading``
    [rad] (``ambiguous``: or ``heading + pi``). ``site`` names it for diagnostics."""

    site: str
    heading: float
    ambiguous: bool
    t: float
    walked: float = 0.0
    directions: list[float] = field(default_factory=list)

    def add(self, d: np.ndarray, cfg: DoorHeadingConfig) -> bool:
        """Add a moving stride's MEMS displacement (2,) [m]; True once ``n_s`` are in."""
        length = float(math.hypot(d[0], d[1]))
        if length <= 0.0:
            return False
        if self.walked >= cfg.clear_distance:
            self.directions.append(math.atan2(d[1], d[0]))
        self.walked += length
        return len(self.directions) >= cfg.strides


@dataclass(frozen=True)
class HeadingMeasurement:
    """Eq. 3 result: ``z`` the measured perturbation [rad], ``var`` its adapted variance
    [rad^2], ``discrepancy`` d [rad], ``crossing`` the resolved door heading [rad] and
    ``accepted`` False when d exceeds the limit."""

    z: float
    var: float
    discrepancy: float
    crossing: float
    mean_mems: float
    accepted: bool


def door_heading_measurement(window: HeadingWindow, dtheta_hat: float,
                             cfg: DoorHeadingConfig) -> HeadingMeasurement:
    """Eq. 3 with the ambiguity resolved and the covariance adapted (module docstring)."""
    u = np.array([[math.cos(a), math.sin(a)] for a in window.directions])
    mean_vec = u.mean(axis=0)
    r = float(np.hypot(*mean_vec))
    mean_mems = math.atan2(mean_vec[1], mean_vec[0])
    spread2 = -2.0 * math.log(max(r, 1e-12))           # circular variance [rad^2]
    corrected = mean_mems + dtheta_hat
    crossing = window.heading
    if window.ambiguous and abs(wrap_angle(crossing + math.pi - corrected)) < abs(wrap_angle(crossing - corrected)):
        crossing = wrap_angle(crossing + math.pi)
    z = wrap_angle(crossing - mean_mems)
    d = wrap_angle(crossing - corrected)
    var = (cfg.sigma ** 2 + spread2 / len(window.directions)) * math.exp(
        min((d / cfg.discrepancy_scale) ** 2, 700.0))
    return HeadingMeasurement(z=z, var=var, discrepancy=d, crossing=crossing,
                              mean_mems=mean_mems, accepted=abs(d) <= cfg.max_discrepancy)
