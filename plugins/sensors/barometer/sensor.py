"""The ``barometer`` sensor class: barometer lines in, a zeroed height per firefighter out."""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field
from typing import ClassVar

from firenav_framework import Params, PerAgent, RawFrame, Sensor, param
from firenav_framework.codecs import FrameError
from firenav_framework.codecs.baro_lines import BaroReading
from firenav_framework.codecs.selection import CodecSelection, TransportCodecs
from firenav_framework.contract import NoBuilding
from firenav_framework.messages import Message, PressureHeight

from .guard import Guard, GuardConfig
from .height import Window, Zeroing, height_above, metres_per_pascal

__all__ = ["BarometerSensor"]


class Frames(CodecSelection):
    """Codecs of the RawFrame inputs, per link transport."""

    record: ClassVar[type] = BaroReading

    codecs: dict[str, str] = param({"serial": "baro_lines", "udp": "baro_lines"})
    """link transport -> codec decoding its lines"""


@dataclass
class _Reference:
    """Recent readings of the reference barometer: (t [s], p [Pa], T [K] or None)."""

    readings: deque = field(default_factory=deque)

    def add(self, t: float, p: float, temperature: float | None, keep: float) -> None:
        self.readings.append((t, p, temperature))
        while self.readings and self.readings[0][0] < t - keep:
            self.readings.popleft()

    def mean_between(self, t0: float, t1: float) -> tuple[float, int] | None:
        """(mean pressure, n) of the readings with ``t0 <= t <= t1``, or None."""
        used = [r[1] for r in self.readings if t0 <= r[0] <= t1]
        return (sum(used) / len(used), len(used)) if used else None

    def at(self, t: float, window: float) -> tuple[float, float, float | None, int] | None:
        """(mean pressure, age [s] of the newest reading, mean temperature, n) of the
        readings in the ``window`` [s] up to ``t``, or None."""
        used = [r for r in self.readings if t - window <= r[0] <= t]
        if not used and self.readings and self.readings[-1][0] <= t:
            used = [self.readings[-1]]  # none that recent: the newest, with its age
        if not used:
            return None
        temps = [r[2] for r in used if r[2] is not None]
        return (sum(r[1] for r in used) / len(used), t - used[-1][0],
                sum(temps) / len(temps) if temps else None, len(used))


@dataclass
class _Wearer:
    window: Window = field(default_factory=Window)
    zeroing: Zeroing = field(default_factory=Zeroing)
    device: str = ""
    zeroed_at: float = math.nan
    guard: Guard = field(default_factory=Guard)


class BarometerSensor(Sensor):
    """Barometer: static pressure to height above the entrance, zeroed against a reference at the entrance or base station."""

    name = "barometer"
    inputs = (RawFrame,)
    outputs = {"height": PressureHeight}

    class Params(Params):
        reference: str = param("base/baro")
        """device id of the reference barometer at the entrance or base station; empty: none
        (weather drift then grows the uncertainty)"""
        devices: dict[str, str] = param({})
        """barometer id -> firefighter, for ids not named '<agent>/<device>'"""
        period: float = param(0.5, unit="s", gt=0)
        """at most one height per firefighter this often (the mean of its readings; the end of the
        data flushes the last one)"""
        calibrate_s: float = param(3.0, unit="s", gt=0)
        """zeroing: the first seconds of a firefighter's readings, at the zeroing level"""
        zero_level: float | None = param(None, unit="m")
        """building z of the zeroing level (default: the floor of the building's first entrance,
        else 0)"""
        air_temperature: float = param(293.15, unit="K", gt=150, lt=400)
        """air temperature of the height formula when the reference reports none"""
        pressure_noise: float = param(2.0, unit="Pa", gt=0)
        """1-sigma noise of one reading (BMP388/MS5611 class: 1-3 Pa)"""
        indoor_offset: float = param(10.0, unit="Pa", ge=0)
        """1-sigma pressure difference inside vs. the reference that zeroing cannot remove (fire,
        doors, ventilation, stack effect)"""
        drift_rate: float = param(0.02, unit="Pa/s", ge=0)
        """1-sigma weather drift per second of an unheard reference (about 1 hPa in 3 h; fronts are
        faster)"""
        reference_window: float = param(10.0, unit="s", gt=0)
        """the reference is the mean of its readings this long before"""
        stuck_readings: int = param(20, ge=3)
        """this many identical readings in a row: the sensor is stuck (a live one's noise changes
        its last digit), readings skipped until it moves"""
        max_step: float = param(100.0, unit="Pa", gt=0)
        """a reading further than this (plus max_rate per second) from the last good one is a jump,
        skipped (a storey is 40 Pa)"""
        max_rate: float = param(30.0, unit="Pa/s", gt=0)
        """fastest real change (2.5 m/s vertical)"""
        rejump_s: float = param(5.0, unit="s", gt=0)
        """readings steady this long at a jumped level: the sensor's offset jumped; taken on with
        the offset moved by the jump (the height carries on from before it)"""
        frames: Frames = param(Frames())
        """RawFrame inputs: the codec per transport and its options"""

    def __init__(self, params: Params, ctx):
        super().__init__(params, ctx)
        self._codecs = TransportCodecs(params.frames, count=ctx.count, resolve=ctx.resolve)
        self._wearers: PerAgent[_Wearer] = PerAgent(lambda agent: _Wearer())
        self._reference = _Reference()
        self._last_t: dict[str, float] = {}

    def start(self) -> None:
        level = self.params.zero_level
        if level is None:
            level = 0.0
            if self.ctx.has_building:
                try:
                    b = self.ctx.building
                    if b.entrances:
                        level = float(b.floor(b.entrances[0].floor).z)
                except NoBuilding:
                    pass
        self.zero_level = level

    def reset(self, agent: str) -> None:
        self._wearers.reset(agent)

    def handle(self, stream: str, msg: Message) -> None:
        if not isinstance(msg, RawFrame):
            self.ctx.count("ignored_messages")
            return
        try:
            readings = self._codecs.decode(msg)
        except FrameError as exc:
            self.ctx.count(exc.code)
            self.ctx.report(msg.t, "baro_bad_line", f"broken barometer lines ({exc})",
                            key=msg.device or "barometer link", agent=msg.agent)
            return
        for r in readings or ():
            self._reading(r, msg.agent)

    # ------------------------------------------------------------------ readings
    def _reading(self, r: BaroReading, link_agent: str) -> None:
        if not math.isfinite(r.t) or r.t <= self._last_t.get(r.device, -math.inf):
            self.ctx.count("out_of_order_readings")
            self.ctx.report(r.t if math.isfinite(r.t) else 0.0, "baro_out_of_order",
                            "barometer readings not after the previous one, skipped",
                            key=r.device, agent=link_agent)
            return
        self._last_t[r.device] = r.t
        if self.params.reference and r.device == self.params.reference:
            self._reference.add(r.t, r.pressure, r.temperature,
                                max(self.params.reference_window, self.params.calibrate_s)
                                + self.params.rejump_s)
            self.ctx.count("reference_readings")
            return
        agent = self.params.devices.get(r.device) or link_agent or (
            r.device.split("/", 1)[0] if "/" in r.device else "")
        if not agent:
            self.ctx.count("unknown_barometers")
            self.ctx.warn_once(r.t, "baro_unknown_device", f"barometer {r.device!r} is "
                               "neither the reference nor named '<agent>/<device>' (set "
                               "devices:); its readings are skipped", key=r.device)
            return
        w = self._wearers[agent]
        w.device = r.device
        if w.zeroing.done and not self._guarded(w, agent, r):
            return
        if not w.zeroing.done:
            if not w.zeroing.add(r.t, r.pressure, self.params.calibrate_s):
                self.ctx.count("zeroing_readings")
                return
            if self.params.reference:
                ref = self._reference.mean_between(w.zeroing.first_t, r.t)
                if ref is None:  # no reference heard while zeroing: start again
                    self.ctx.count("zeroings_without_reference")
                    self.ctx.report(r.t, "baro_no_reference", "no reading of the reference "
                                    f"barometer {self.params.reference!r} while zeroing; "
                                    "zeroing again", key=r.device, agent=agent)
                    w.zeroing = Zeroing()
                    return
                w.zeroing.close(*ref)
            else:
                w.zeroing.close()
            w.zeroed_at = r.t
            self.ctx.diagnose(r.t, "info", "baro_zeroed", f"{r.device}: zeroed on "
                              f"{w.zeroing.n} readings at the level z={self.zero_level:g} m "
                              f"(offset to the reference {w.zeroing.offset:+.1f} Pa)"
                              if self.params.reference else
                              f"{r.device}: zeroed on {w.zeroing.n} readings at the level "
                              f"z={self.zero_level:g} m, no reference: weather drift grows "
                              "the uncertainty", agent=agent)
        if w.window.n and r.t - w.window.start >= self.params.period:
            self._emit(agent, w, w.window.last_t)
        w.window.add(r.t, r.pressure)

    def _guarded(self, w: _Wearer, agent: str, r: BaroReading) -> bool:
        """Whether a zeroed wearer's reading is good (stuck and jumped ones are counted,
        reported and skipped; a jump that stays moves the zeroing offset)."""
        p = self.params
        verdict = w.guard.check(r.t, r.pressure, GuardConfig(
            stuck_readings=p.stuck_readings, max_step=p.max_step, max_rate=p.max_rate,
            rejump_s=p.rejump_s))
        if verdict == "ok":
            return True
        if verdict == "offset_jump":
            if w.window.n:         # the readings before the jump, with the offset then
                self._emit(agent, w, w.window.last_t)
            w.zeroing.offset += w.guard.last_shift
            self.ctx.count("offset_jumps")
            self.ctx.report(r.t, "baro_offset_jump", f"{r.device}: readings steady "
                            f"{w.guard.last_shift:+.0f} Pa from before for {p.rejump_s:g} s: "
                            "the sensor's offset jumped, taken on with the zeroing moved by "
                            "it", key=r.device, agent=agent)
            return True
        self.ctx.count(f"{verdict}_readings")
        what = ("the same reading repeated: stuck sensor" if verdict == "stuck" else
                f"a jump of {r.pressure - w.guard.last_p:+.0f} Pa from the last good reading")
        self.ctx.report(r.t, f"baro_{verdict}", f"{r.device}: {what}; readings skipped",
                        key=r.device, agent=agent)
        return False

    def _emit(self, agent: str, w: _Wearer, t: float) -> None:
        p = self.params
        pressure = w.window.mean()
        interval = t - w.window.start
        n = w.window.n
        w.window.clear()
        zeroing = w.zeroing
        noise2 = p.pressure_noise ** 2 * (1.0 / n + 1.0 / zeroing.n
                                          + (1.0 / zeroing.n_reference if p.reference else 0.0))
        temperature = p.air_temperature
        if p.reference:
            ref = self._reference.at(t, p.reference_window)
            if ref is None:  # no reference reading up to t (heard only after it): skipped
                self.ctx.count("heights_without_reference")
                return
            ref_p, age, ref_temp, ref_n = ref
            reference = ref_p + w.zeroing.offset
            noise2 += p.pressure_noise ** 2 / ref_n
            if ref_temp is not None:
                temperature = ref_temp
        else:
            reference, age = w.zeroing.offset, t - w.zeroed_at
        sigma_p = math.sqrt(noise2 + p.indoor_offset ** 2 + (p.drift_rate * age) ** 2)
        height = self.zero_level + height_above(reference, pressure, temperature)
        sigma = metres_per_pascal(pressure, temperature) * sigma_p
        self.ctx.count("heights")
        self.ctx.publish("height", PressureHeight(
            t=t, agent=agent, device=w.device, height=height, sigma=sigma, pressure=pressure,
            reference_pressure=reference, reference_age=age, interval=interval,
            zero_level=self.zero_level))

    def finish(self) -> None:
        for agent, w in self._wearers.items():
            if w.zeroing.done and w.window.n:
                self._emit(agent, w, w.window.last_t)
