"""The building's stair flights, and the heights a walk can rest on.

The RFID/MEMS paper gets the height by counting stairs at a nominal 20 cm ("MEMS
Navigation Module"). A building model tells much more: where each flight is, which way
it climbs, how many stairs it has and the level at each of its ends, so that a flight
walked from end to end moves the height by exactly its rise (:mod:`.flight_tracker`).

The flights of a stair are the building model's (:meth:`~firenav_framework.building.Stair.flights`:
a U-shaped stair is flight - landing - flight, each flight a ``Stair`` of its own with its
rise, step height and length); this module adds what the estimator asks of them.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from firenav_framework.building import Building, Stair

__all__ = ["Flight", "StairFlights", "stair_flights", "snap_levels"]


def _of_geometry(name: str, doc: str) -> property:
    """A read-only property of :class:`Flight` that is ``geometry.<name>``."""
    return property(lambda flight: getattr(flight.geometry, name), doc=doc)


@dataclass(frozen=True, eq=False)
class Flight:
    """One flight of stairs as the estimator walks it: ``geometry`` is the flight as the
    building model gives it (:meth:`Stair.flights`, climbing from its lower end), ``index``
    its place in its stair (0 = lowest flight)."""

    index: int
    geometry: Stair

    stair = _of_geometry("id", "Id (str) of the building's stair the flight belongs to.")
    path = _of_geometry("path", "Walking line (K, 2) [m] from the lower to the upper end.")
    z_lo = _of_geometry("z_from", "Level of the lower end [m].")
    z_hi = _of_geometry("z_to", "Level of the upper end [m].")
    steps = _of_geometry("n_steps", "Number of stairs (int).")
    width = _of_geometry("width", "Width of the flight [m].")
    rise = _of_geometry("rise", "Height climbed from the lower to the upper end [m].")
    step_rise = _of_geometry("step_height", "Height of one stair [m].")

    @cached_property
    def length(self) -> float:
        """Horizontal length of the walking line [m] (asked for every stride on it)."""
        return self.geometry.length

    @property
    def tread(self) -> float:
        """Horizontal going of one stair along the walking line [m]."""
        return self.length / self.steps

    def entry_level(self, sign: int) -> float:
        """Level [m] of the end a walk *enters* by when climbing (``sign`` +1: the lower
        end) or descending (-1: the upper end)."""
        return self.z_lo if sign > 0 else self.z_hi

    def locate(self, xy: np.ndarray) -> tuple[float, np.ndarray]:
        """Horizontal distance [m] of ``xy`` (2,) from the walking line, and the climb
        direction (2,) (unit, lower to upper end) of the line's segment nearest to it."""
        best, axis = math.inf, self.path[1] - self.path[0]
        for a, b in zip(self.path[:-1], self.path[1:]):
            ab = b - a
            u = float(np.clip(np.dot(xy - a, ab) / max(float(ab @ ab), 1e-12), 0.0, 1.0))
            dist = float(np.hypot(*(a + u * ab - xy)))
            if dist < best:
                best, axis = dist, ab
        return best, axis / max(float(np.hypot(*axis)), 1e-12)


def stair_flights(stair: Stair) -> list[Flight]:
    """The flights of one stair of the building, lowest first (:meth:`Stair.flights`)."""
    return [Flight(k, f) for k, f in enumerate(stair.flights())]


def snap_levels(building: Building) -> np.ndarray:
    """Sorted heights [m] a walk can rest on: every floor level and every landing."""
    levels = [f.z for f in building.floors]
    for s in building.stairs:
        levels += [f.z_hi for f in stair_flights(s)[:-1]]
    return np.unique(np.round(levels, 6))


class StairFlights:
    """The flights of a building with the queries the estimator makes about them.

    ``zone`` [m]: how far from a flight's walking line (beyond half its width) a
    position estimate may be and still be on that flight (the estimate is metres off at
    worst, the stairwell's flights a few metres apart).
    """

    def __init__(self, building: Building | None, zone: float):
        stairs = building.stairs if building is not None else []
        self.flights: list[Flight] = [f for s in stairs for f in stair_flights(s)]
        self.zone = zone

    def __len__(self) -> int:
        return len(self.flights)

    def _reach(self, f: Flight) -> float:
        return 0.5 * f.width + self.zone

    def near(self, position: np.ndarray) -> Flight | None:
        """The flight nearest to ``position`` (3,) [m] within the zone and within a metre
        of its height range, or None."""
        x, y, z = (float(v) for v in position[:3])
        best, found = math.inf, None
        for f in self.flights:
            if not f.z_lo - 1.0 <= z <= f.z_hi + 1.0:
                continue
            dist, _ = f.locate(np.array([x, y]))
            if dist <= self._reach(f) and dist < best:
                best, found = dist, f
        return found

    def leaving(self, stair: str, level: float, sign: int) -> Flight | None:
        """The flight of ``stair`` a walk going up (``sign`` +1) or down (-1) enters at
        ``level`` [m], or None."""
        for f in self.flights:
            if f.stair == stair and abs(f.entry_level(sign) - level) < 1e-6:
                return f
        return None

    def is_landing(self, stair: str, level: float) -> bool:
        """Whether ``level`` [m] is a mid-storey landing of ``stair``: flights leave it
        both up and down."""
        return (self.leaving(stair, level, 1) is not None
                and self.leaving(stair, level, -1) is not None)

    def step_rise_at(self, position: np.ndarray) -> float | None:
        """Height of one stair [m] of the flight at ``position`` (3,), or None."""
        f = self.near(position)
        return None if f is None else f.step_rise

    def entry(self, xy: np.ndarray, z: float, sign: int, d: np.ndarray,
              axis_cos: float, min_treads: float) -> Flight | None:
        """The flight a stair stride enters: climbing (``sign`` +1) from a lower end or
        descending (-1) from an upper end whose level is within half the flight's rise of
        ``z`` [m], the stride ending at ``xy`` (2,) within the zone of its walking line
        and its horizontal displacement ``d`` (2,) [m] going that way along the flight
        (cosine at least ``axis_cos``, at least ``min_treads`` treads). The nearest one."""
        length = float(np.hypot(*d))
        best, found = math.inf, None
        for f in self.flights:
            if abs(z - f.entry_level(sign)) > 0.5 * f.rise:
                continue
            dist, axis = f.locate(xy)
            if dist > self._reach(f):
                continue
            advance = sign * float(d @ axis)
            if advance < axis_cos * length or advance < min_treads * f.tread:
                continue
            if dist < best:
                best, found = dist, f
        return found

