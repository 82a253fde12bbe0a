"""Pressure to height: the hypsometric equation, and a barometer's zeroing state.

Height difference between two pressures in a column of air at temperature ``T``
(the hypsometric equation of any atmospheric-science text, e.g. Wallace & Hobbs,
*Atmospheric Science*, ch. 3, with the virtual temperature taken as ``T``)::

    h2 - h1 = (R_d T / g) ln(p1 / p2)

with ``R_d`` = 287.05 J/(kg K) the gas constant of dry air and ``g`` = 9.80665 m/s^2;
at 293 K one hectopascal is about 8.5 m (0.085 m per Pa near sea level). A 30 K error
in ``T`` scales a height by 10 % (1 m over three storeys).

Zeroing cancels what two barometers disagree on: the firefighter's reading and the
reference's differ by a sensor offset (commonly +-100 Pa, i.e. +-8 m, between two
parts) and by their height difference. Over the first ``calibrate_s`` seconds of a
firefighter's data, standing at the zeroing level (the entrance, as for the INS
alignment), the mean difference ``offset = p_ff - p_ref`` is taken; after that the
height above the zeroing level is ``(R_d T / g) ln((p_ref + offset) / p_ff)``, and
weather (which moves both) cancels. Without a reference the pressure at zeroing is the
reference, and the weather's drift since then is in the uncertainty.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["R_DRY", "G0", "height_above", "metres_per_pascal", "Zeroing", "Window"]

R_DRY = 287.05     # J/(kg K), specific gas constant of dry air
G0 = 9.80665       # m/s^2, standard gravity


def height_above(p_ref: float, p: float, temperature: float) -> float:
    """Height [m] of pressure ``p`` [Pa] above the level of ``p_ref`` [Pa] at
    ``temperature`` [K]."""
    return R_DRY * temperature / G0 * math.log(p_ref / p)


def metres_per_pascal(p: float, temperature: float) -> float:
    """|dh/dp| [m/Pa] at pressure ``p`` [Pa] and ``temperature`` [K]."""
    return R_DRY * temperature / (G0 * p)


@dataclass
class Window:
    """Readings of one firefighter's barometer since the last report."""

    start: float = math.nan
    total: float = 0.0
    n: int = 0
    last_t: float = -math.inf

    def add(self, t: float, p: float) -> None:
        if self.n == 0:
            self.start = t
        self.total += p
        self.n += 1
        self.last_t = t

    def mean(self) -> float:
        return self.total / self.n

    def clear(self) -> None:
        self.start, self.total, self.n = math.nan, 0.0, 0


@dataclass
class Zeroing:
    """One firefighter's zeroing: its mean pressure [Pa] over the first ``calibrate_s``
    seconds, less the reference's mean over the same seconds (with a reference)."""

    first_t: float = math.nan
    total: float = 0.0
    n: int = 0
    n_reference: int = 0
    done: bool = False
    offset: float = math.nan

    def add(self, t: float, p: float, calibrate_s: float) -> bool:
        """Take one reading at ``t`` [s]; True once the zeroing time is over (then
        :meth:`close` it)."""
        if math.isnan(self.first_t):
            self.first_t = t
        if t - self.first_t >= calibrate_s and self.n:
            return True
        self.total += p
        self.n += 1
        return False

    def close(self, reference_mean: float = 0.0, n_reference: int = 0) -> None:
        """Zeroed: ``offset`` = own mean - ``reference_mean`` (the reference's mean
        over the zeroing seconds, of ``n_reference`` readings; 0 without one)."""
        self.offset = self.total / self.n - reference_mean
        self.n_reference = n_reference
        self.done = True
