"""Height from the building's stair flights: the floor changes when a flight is completed.

Counting stairs stride by stride (the paper's "MEMS Navigation Module") lets every
error of the foot INS's height reach the floor output: on the simulated Xsens MTx
grade a descending stride of two 17.5 cm stairs shows only -0.27 m on average, and the
level strides on a landing right after a descent +0.08 m, enough to be counted as a
climb. With the building's flights (:mod:`.height`) the per-stride evidence only has to
say *whether* the agent walks a flight, not exactly how high:

* a stair stride (gait class SC, SDF or SDB, :mod:`.gait`) **enters** a flight only
  where the building has one going that way: from its lower end when climbing, from its
  upper end when descending, that end's level within half the flight's rise of the
  estimated height, the estimated position within the stair zone of its walking line,
  and the stride's horizontal displacement going along the flight in the climb (or
  descent) direction. Whatever the facing: a backward descent moves down the flight
  too. Stair-like strides anywhere else are level (a landing crossed sideways, a
  corridor). At a **known stair end** a stair stride enters the stair's flight that
  leaves it in the stride's sign, wherever the estimate is and whichever way it goes:
  on a mid-storey landing a run of the stair completed onto, on in the same direction
  (a landing has no other way on, and the estimated heading is least trustworthy right
  there, after the turn onto it; the way back needs the building's geometry, as the
  INS often shows a small false climb on the level strides after a descent), or
  within ``zone`` metres walked after a read of the tag at the stair's bottom or top (:meth:`FlightTracker.at_stair_end`; the estimate may be metres and tens of
  degrees off when the tag relocates it). The read arrives seconds late (the reader
  closes a pass after it), so the last few strides off any flight since the read are
  walked again from that end, those whose INS height moves ``weak_rise`` of a stair
  into the stair taken as stair strides;
* on the flight, each stride going on in the run's own direction counts its stairs:
  the larger of the rise's and the stride length's number of stairs (rise over the
  stair's rise, length over its tread), rounded, one to ``max_per_stride`` (the INS
  measures the length of a stride far better than its rise). The run's direction is
  that of its strides so far, in the building frame as estimated: a flight is straight,
  so this needs the INS heading over a few seconds only, not the estimated heading's
  agreement with the building. A stride the gait calls level still counts as a stair
  stride when the INS height moves the run's way by ``weak_rise`` of a stair (on a
  flight a stair is likely; the gait classifier, which must work anywhere, asks for
  more). One stride that goes on in the run's direction but level, or, after two stair
  strides, even the other way by its rise (an INS glitch: turning back moves back
  along the flight), is counted by its length; a second one in a row ends the run.
  Strides shorter than ``min_treads`` treads (shuffling, turning on the spot) neither
  count nor end the run;
* the run **ends** with a stride that turns away from the run's direction, a second
  level stride, or a stride after every stair of the flight was counted. The flight is
  then **completed** when at least ``complete_fraction`` of its stairs were counted
  *and* the INS height changed by at least ``rise_fraction`` of its rise (strides
  against the run count as zero; the simulated INS shows 0.76 of a descent, one stride
  may be lost to the entry, a false run on a landing shows 0.2): the height is set to
  the level of its far end. Otherwise the
  agent **left** it where it entered (a few stair-like strides on a landing, or turning
  back), and the height goes back to that level. The stride that ended a run may enter
  the next flight.

The ``still`` strides (rest events) neither count nor end a run.
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field, replace

import numpy as np

from .height import Flight, StairFlights

__all__ = ["FlightConfig", "FlightStep", "FlightTracker"]

#: Strides off any flight remembered for a stair-end tag read that arrives after them.
RECENT_STRIDES = 8
#: Gait classes -> direction of travel on a flight (+1 up, -1 down, 0 level).
GAIT_SIGN = {"SC": 1, "SDF": -1, "SDB": -1, "FW": 0}


@dataclass(frozen=True)
class FlightConfig:
    """Thresholds of the flight tracker (SI units)."""

    axis_cos: float = math.cos(math.radians(60.0))   # stride direction vs. flight axis
    min_treads: float = 0.5        # a stride on a flight advances at least this many treads
    weak_rise: float = 0.3         # [stairs] INS rise the run's way that continues a run
    complete_fraction: float = 0.5  # share of a flight's stairs that completes it ...
    rise_fraction: float = 0.4     # ... with this share of its rise in the INS height
    max_per_stride: int = 2        # stairs per stride of the instrumented foot
    step_height: float | None = None   # [m] counted rise of one stair (None: the flight's)


@dataclass(frozen=True)
class FlightStep:
    """What one stride did to the height: ``z`` [m] after it; ``stairs`` counted on it
    (signed); ``settled`` True when ``z`` was just set from the building (a run ended at
    a level, or began at one); ``ended`` '', 'complete' or 'left', ``entered`` True when
    a run began, with the ``flight`` concerned; ``vetoed`` True for a stair-like stride
    that is no flight's (a level stride)."""

    z: float
    stairs: int = 0
    settled: bool = False
    ended: str = ""
    entered: bool = False
    flight: Flight | None = None
    vetoed: bool = False


@dataclass(frozen=True)
class _End:
    """A known stair end: ``stair``, its ``level`` [m], the ``sign`` of the flight a stair
    stride may take from it whatever the estimate (+1 up, -1 down), and the distance
    [m] that may still be walked level before it is forgotten (``budget``)."""

    stair: str
    level: float
    sign: int
    budget: float = math.inf


@dataclass
class _Run:
    flight: Flight
    sign: int
    z0: float            # level of the end entered by [m]
    stairs: int = 0      # counted so far
    strides: int = 1     # stair strides of the run's sign
    rise: float = 0.0    # INS height change in the run's direction, strides against it as 0 [m]
    misses: int = 0      # consecutive level strides along the flight
    came_from: _End | None = None   # the known stair end stood at when the run began
    way: np.ndarray = field(default_factory=lambda: np.zeros(2))   # sum of its strides [m]

    @property
    def full(self) -> bool:
        return self.stairs >= self.flight.steps

    def height(self) -> float:
        return self.z0 + self.sign * min(self.stairs, self.flight.steps) * self.flight.step_rise


class FlightTracker:
    """Per-agent state machine over the building's flights (module docstring)."""

    def __init__(self, flights: StairFlights, config: FlightConfig | None = None):
        self.flights = flights
        self.cfg = config or FlightConfig()
        self.run: _Run | None = None
        # (stair, level [m], metres that may still be walked level) of a known stair end
        self.at_end: _End | None = None
        # (t, gait, dz, d, xy) of the latest strides walked off any flight
        self._recent: deque = deque(maxlen=RECENT_STRIDES)

    def stride(self, gait: str, dz: float, d: np.ndarray, xy: np.ndarray, z: float,
               t: float = math.nan) -> FlightStep:
        """One stride ending at time ``t`` [s]: gait class, drift-corrected INS height
        change ``dz`` [m], horizontal displacement ``d`` (2,) [m] and end position ``xy``
        (2,) [m] in the building frame, estimated height ``z`` [m] before it."""
        step = self._stride(gait, dz, d, xy, z)
        if self.run is None:
            self._recent.append((t, gait, dz, d, xy))
        else:
            self._recent.clear()
        return step

    def _stride(self, gait: str, dz: float, d: np.ndarray, xy: np.ndarray, z: float
                ) -> FlightStep:
        if gait == "still":
            return FlightStep(z)
        sign = GAIT_SIGN.get(gait, 0)
        if self.run is not None:
            step = self._continue(sign, dz, d)
            if step is not None:
                return step
            ended = self._end()
            entered = self._enter(sign, dz, d, xy, ended.z)
            if entered.entered:
                return replace(entered, ended=ended.ended)
            return replace(ended, vetoed=entered.vetoed)
        return self._enter(sign, dz, d, xy, z)

    @property
    def on_stairs(self) -> bool:
        """Whether the agent is on a flight or at a known stair end, wherever the
        position estimate is."""
        return self.run is not None or self.at_end is not None

    def abandon(self) -> None:
        """Forget the run being walked and the stair end stood at (the height was set
        from elsewhere, e.g. a tag)."""
        self.run = self.at_end = None

    def at_stair_end(self, stair: str, level: float, t: float = math.inf) -> FlightStep | None:
        """The tag at an end (bottom or top, at ``level`` [m]) of ``stair`` was read at
        time ``t`` [s]: the next stair stride into the stair, within ``zone`` metres
        walked, enters it, and so may the strides already walked since ``t``. Returns
        the height those strides lead to (None: they entered no flight)."""
        if self.run is not None:
            return None
        into = (self.flights.leaving(stair, level, 1), self.flights.leaving(stair, level, -1))
        sign = 1 if into[0] is not None else -1
        f = into[0] or into[1]
        later = [r for r in self._recent if r[0] > t]
        self._recent.clear()
        if f is None:
            return None
        self.at_end = _End(stair, level, sign, self.flights.zone)
        if not later:
            return None
        z, step = level, None
        for _, gait, dz, d, xy in later:
            if sign * dz >= self.cfg.weak_rise * f.step_rise:
                gait = "SC" if sign > 0 else "SDF"
            step = self._stride(gait, dz, d, xy, z)
            z = step.z
        return step if z != level or self.run is not None else None

    # -- a run on a flight ---------------------------------------------------------------
    def _continue(self, sign: int, dz: float, d: np.ndarray) -> FlightStep | None:
        """The stride goes on along the run's flight (its step), or None: the run ends."""
        run = self.run
        f = run.flight
        length = float(np.hypot(*d))
        if length < self.cfg.min_treads * f.tread:
            return FlightStep(run.height())     # shuffling on the spot: no stair, no exit
        if run.full or not self._onward(run, d) or (sign == -run.sign and run.strides < 2):
            return None
        run.rise += max(0.0, run.sign * dz)
        run.way += d
        if sign == run.sign or run.sign * dz >= self.cfg.weak_rise * f.step_rise:
            run.misses = 0
            run.strides += 1
            n = self._count(f, dz, length)
        else:          # along the flight but level or even against it by its rise:
            run.misses += 1                     # the INS missed the stairs (once)
            if run.misses > 1:
                return None
            n = self._count(f, 0.0, length)
        run.stairs += n
        return FlightStep(run.height(), run.sign * n)

    def _onward(self, run: _Run, d: np.ndarray) -> bool:
        """Whether displacement ``d`` goes on in the run's direction, by at least
        ``min_treads`` treads."""
        way = run.way / max(float(np.hypot(*run.way)), 1e-12)
        advance = float(d @ way)
        return (advance >= self.cfg.axis_cos * float(np.hypot(*d))
                and advance >= self.cfg.min_treads * run.flight.tread)

    def _count(self, f: Flight, dz: float, length: float) -> int:
        """Stairs of one stride on flight ``f``: rise ``dz`` [m] or horizontal ``length``
        [m] in treads, whichever is more, rounded, 1 to ``max_per_stride``."""
        rise = self.cfg.step_height or f.step_rise
        n = round(max(abs(dz) / rise, length / f.tread))
        return int(min(max(n, 1), self.cfg.max_per_stride))

    def _end(self) -> FlightStep:
        run, self.run = self.run, None
        f = run.flight
        if (run.stairs >= self.cfg.complete_fraction * f.steps
                and run.rise >= self.cfg.rise_fraction * f.rise):
            far = f.entry_level(-run.sign)
            self.at_end = (_End(f.stair, far, run.sign)
                           if self.flights.is_landing(f.stair, far) else None)
            return FlightStep(far, settled=True, ended="complete", flight=f)
        self.at_end = run.came_from          # back where it was
        return FlightStep(run.z0, settled=True, ended="left", flight=f)

    def _enter(self, sign: int, dz: float, d: np.ndarray, xy: np.ndarray, z: float
               ) -> FlightStep:
        # before the level-stride return on purpose: a level stride, too, uses up the
        # distance that may still be walked from a stair end since its tag was read
        f = self._from_end(sign, z, float(np.hypot(*d)))
        if sign == 0:
            return FlightStep(z)
        if f is None:
            f = self.flights.entry(xy, z, sign, d, self.cfg.axis_cos, self.cfg.min_treads)
        if f is None:
            return FlightStep(z, vetoed=True)
        self.run = _Run(f, sign, f.entry_level(sign), stairs=self._count(f, dz, float(np.hypot(*d))),
                        rise=max(0.0, sign * dz), way=d.astype(float), came_from=self.at_end)
        self.at_end = None
        return FlightStep(self.run.height(), sign * self.run.stairs, True, entered=True,
                          flight=f)

    def _from_end(self, sign: int, z: float, length: float) -> Flight | None:
        """The flight a stride of ``sign`` and horizontal ``length`` [m] enters from the
        known stair end (height ``z`` [m] within half the flight's rise of its level), or
        None; a level stride uses up the distance that may be walked from a tag's end."""
        end = self.at_end
        if end is None:
            return None
        if sign == 0:
            self.at_end = (replace(end, budget=end.budget - length)
                           if end.budget > length else None)
            return None
        if sign != end.sign:
            return None
        f = self.flights.leaving(end.stair, end.level, sign)
        return f if f is not None and abs(z - end.level) <= 0.5 * f.rise else None
