"""The radio's path-loss model learned online from links of known length (beyond §V).

The ``rssi_breadcrumb`` sensor turns an RSSI into a range with its configured
log-distance model ``RSSI = P0 - 10 n0 log10 r`` (P0 the RSSI at 1 m [dBm], n0 the
exponent). A building's true model ``RSSI = P - 10 n log10 d + X`` differs (the simulator
draws P within 4 dB and n within 2.0-3.6 per building), and the two are related by a
straight line in log range:

    log10 r = c + e log10 d + X / (10 n0),   c = (P0 - P) / (10 n0),   e = n / n0,

so the building's exponent is ``n = e n0`` and its RSSI at 1 m ``P = P0 - 10 n0 c``. The
shadowing X is in the RSSI, hence in ``log10 r``: the line is fitted with the known
length as the regressor (the other way round would be biased by the noise). The
estimator learns ``(c, e)`` from links whose length the graph knows well: a breadcrumb
and the firefighter who dropped it over the next few steps (their relative position
comes from a few metres of odometry), and the base station and a firefighter over the
first steps after the start. It is a Bayesian linear regression with a prior at the
sensor's own model (``c = 0``, ``e = 1``); every range and encounter is then corrected
with the posterior mean, ``log10 d = (log10 r - c) / e``. Nothing here reads the
simulator's parameters.
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["PathLossLearner"]

LN10 = math.log(10.0)


class PathLossLearner:
    """Recursive least squares of ``log10 r = c + e log10 d`` with a Gaussian prior.

    ``sigma_offset`` [decades] (of c) and ``sigma_slope`` [-] (of e) are the prior
    standard deviations about the sensor's model; ``sigma_log`` [decades] is one
    observation's spread (shadowing and fading over ``10 n0``); ``min_samples``
    observations are needed before the correction is applied.
    """

    def __init__(self, sigma_offset: float, sigma_slope: float, sigma_log: float,
                 min_samples: int) -> None:
        self._info = np.diag([1.0 / sigma_offset ** 2, 1.0 / sigma_slope ** 2])
        self._eta = self._info @ np.array([0.0, 1.0])
        self._w = 1.0 / sigma_log ** 2
        self._min = min_samples
        self.samples = 0
        self._sq = 0.0          # sum of squared residuals at the estimate of the time

    def observe(self, r_sensor: float, d_known: float) -> None:
        """One link: the sensor's range ``r_sensor`` [m] of a link ``d_known`` [m] long."""
        if not (r_sensor > 0 and d_known > 0 and math.isfinite(r_sensor)
                and math.isfinite(d_known)):
            return
        h = np.array([1.0, math.log10(d_known)])
        y = math.log10(r_sensor)
        c, e = self.coefficients
        self._sq += (y - c - e * h[1]) ** 2
        self._info += self._w * np.outer(h, h)
        self._eta += self._w * y * h
        self.samples += 1

    @property
    def ready(self) -> bool:
        return self.samples >= self._min

    @property
    def coefficients(self) -> tuple[float, float]:
        """Posterior mean ``(c [decades], e [-])``."""
        c, e = np.linalg.solve(self._info, self._eta)
        return float(c), float(e)

    @property
    def residual_sigma(self) -> float:
        """RMS residual [decades] of the observations so far (their shadowing)."""
        return math.sqrt(self._sq / self.samples) if self.samples else math.nan

    def correct(self, r_sensor: float, sigma_sensor: float) -> tuple[float, float]:
        """(range [m], sigma [m]) of a sensor range under the learned model (unchanged
        until ``ready``). The sigma is the sensor's relative spread, or the observed
        residual spread where that is larger, divided by ``e``."""
        if not self.ready or not r_sensor > 0:
            return r_sensor, sigma_sensor
        c, e = self.coefficients
        e = max(e, 0.2)
        d = 10.0 ** ((math.log10(r_sensor) - c) / e)
        rel = max(sigma_sensor / r_sensor, LN10 * self.residual_sigma) / e
        return d, d * rel

    def exponent_and_rssi_1m(self, n0: float, p0_dbm: float) -> tuple[float, float]:
        """The learned model as an exponent ``n`` and RSSI at 1 m [dBm], given the
        sensor's ``n0`` and ``P0``."""
        c, e = self.coefficients
        return e * n0, p0_dbm - 10.0 * n0 * c
