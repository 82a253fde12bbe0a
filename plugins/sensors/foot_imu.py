"""The ``foot_imu`` sensor: any foot-IMU input to clean, calibrated FLU blocks.

Inputs are :class:`ImuBlock` in a device frame (recordings, the simulator) or
:class:`RawFrame` from a live link or its log (CAN frames described by a DBC file,
MAVLink HIGHRES_IMU / SCALED_IMU / RAW_IMU, text lines over serial or UDP). For
each device the sensor

1. converts units to SI (``accel_unit`` ... for blocks and text lines; CAN and
   MAVLink frames carry their own) and, for frames, maps the device clock onto the
   pipeline clock and collects samples into blocks of ``block_s``;
2. screens the samples (:mod:`.imu_quality`): NaN/inf, out of range, corrupt
   timestamps, duplicates and time going backwards are dropped; saturation and
   gaps are flagged in ``ImuBlock.flags``; everything is counted (run summary) and
   the serious problems are reported as diagnostics, at most one per device and
   problem every ``report_interval`` seconds;
3. applies the device's calibration (:mod:`.imu_calibration`) and rotates the
   axes to FLU (x toe, y left, z up: about +9.81 m/s^2 on z at rest);
4. publishes the block on ``imu`` and, once per device, checks that gravity points
   up and that the units look right at rest (a wrong ``axes`` or unit is the most
   common set-up mistake).
"""
from __future__ import annotations

import fnmatch
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from pydantic import field_validator, model_validator

from firenav_framework.contract import Context, Params, Sensor, param
from firenav_framework.messages import ImuBlock, RawFrame
from firenav_framework.formats.imu_csv import UNIT_SCALES

from .imu_calibration import CalibrationFile, LinearCorrection, axes_matrix, load_calibration
from .imu_can import CanImuDecoder
from .imu_frames import DeviceClock, FrameError, LineImuDecoder
from .imu_mavlink import MavlinkImuDecoder
from .imu_quality import DeviceHistory, QualityLimits, screen

GRAVITY = 9.81  # m/s^2, for the at-rest checks

#: Screening counts -> (run-summary name, diagnostic text or None for count only).
_SCREEN_REPORTS = {
    "nonfinite": ("nonfinite_samples", "samples with NaN/inf values dropped"),
    "out_of_range": ("out_of_range_samples", "samples beyond the plausible range dropped"),
    "time_outlier": ("time_outlier_samples", "samples with a corrupt timestamp dropped"),
    "duplicate": ("duplicate_samples", None),
    "time_backwards": ("time_backwards_samples", "samples whose time went backwards dropped"),
    "saturated": ("saturated_samples", "saturated samples (kept, flagged)"),
    "gaps": ("gaps", "gaps in the data"),
}
#: Frame problems -> (diagnostic level, text).
_FRAME_REPORTS = {
    "bad_frames": ("warning", "frames that could not be decoded skipped"),
    "unknown_can_ids": ("info", "CAN frames with ids the DBC does not describe skipped "
                                "(other devices on the bus, or a node missing from the DBC)"),
    "raw_imu_unscaled": ("error", "RAW_IMU packets skipped: set raw_accel_scale and "
                                  "raw_gyro_scale"),
    "incomplete_samples": ("warning", "samples missing some of their CAN frames dropped"),
    "clock_resyncs": ("warning", "device clock jumps: time re-anchored to the frames"),
}
_MAX_BUFFER = 4096  # samples collected from frames before a block is forced out
_CHECK_WINDOW_S = 10.0  # at-rest checks give up after this much data


@dataclass
class _Pending:
    """What a reporter has seen of one (device, problem) since its last diagnostic."""

    agent: str
    level: str
    text: str
    t: float = 0.0
    n: int = 0
    worst: float = 0.0


class _Reporter:
    """Diagnostics rate-limited per (device, code), with the counts in between summed.

    The first occurrence is reported at once; later ones at most every ``interval``
    seconds of data time. What is still pending is reported by :meth:`flush`.
    """

    def __init__(self, ctx: Context, interval: float):
        self.ctx = ctx
        self.interval = interval
        self._last: dict[tuple[str, str], float] = {}
        self._pending: dict[tuple[str, str], _Pending] = {}

    def report(self, t: float, agent: str, device: str, code: str, n: int, text: str,
               level: str = "warning", worst: float = 0.0) -> None:
        key = (device, code)
        p = self._pending.setdefault(key, _Pending(agent, level, text))
        p.t, p.n, p.worst = t, p.n + n, max(p.worst, worst)
        last = self._last.get(key)
        if last is None or t - last >= self.interval:
            self._emit(key)

    def _emit(self, key: tuple[str, str]) -> None:
        p = self._pending.pop(key)
        device, code = key
        detail = f" (longest {p.worst:.2f} s)" if p.worst else ""
        since = self._last.get(key)
        window = f" since t={since:.1f} s" if since is not None else ""
        self.ctx.diagnose(p.t, p.level, f"imu_{code}",
                          f"{device or '?'}: {p.n} {p.text}{detail}{window}", agent=p.agent)
        self._last[key] = p.t

    def flush(self) -> None:
        for key in list(self._pending):
            self._emit(key)


@dataclass(frozen=True)
class _Samples:
    """One device's samples in arrival order: SI units, device axes."""

    time: np.ndarray                # (n,) s
    accel: np.ndarray               # (n, 3) m/s^2
    gyro: np.ndarray                # (n, 3) rad/s
    mag: np.ndarray | None          # (n, 3) uT
    flags: np.ndarray               # (n,) uint8

    def __len__(self) -> int:
        return len(self.time)

    def take(self, index: np.ndarray | slice) -> "_Samples":
        return _Samples(self.time[index], self.accel[index], self.gyro[index],
                        None if self.mag is None else self.mag[index], self.flags[index])

    def then(self, later: "_Samples") -> "_Samples":
        """These samples followed by ``later``."""
        mag = None
        if self.mag is not None or later.mag is not None:
            mag = np.concatenate([np.full((len(x), 3), np.nan) if x.mag is None else x.mag
                                  for x in (self, later)])
        return _Samples(np.concatenate((self.time, later.time)),
                        np.concatenate((self.accel, later.accel)),
                        np.concatenate((self.gyro, later.gyro)), mag,
                        np.concatenate((self.flags, later.flags)))


@dataclass
class _Device:
    """One output IMU stream: screening memory, corrections, frame buffer, checks."""

    agent: str
    device: str
    accel: LinearCorrection
    gyro: LinearCorrection
    mag: LinearCorrection
    history: DeviceHistory = field(default_factory=DeviceHistory)
    buffer: list[tuple] = field(default_factory=list)
    buffer_t0: float | None = None  # first finite sample time in the buffer
    held: _Samples | None = None  # a last sample that leapt ahead, awaiting its successor
    first_t: float | None = None
    units_checked: bool = False
    axes_checked: bool = False
    window: list[np.ndarray] = field(default_factory=list)  # (n, 6) FLU accel+gyro


class FootImuSensor(Sensor):
    """Decode, screen, calibrate and rotate foot-IMU data to FLU ImuBlocks."""

    name = "foot_imu"
    inputs = (ImuBlock, RawFrame)
    outputs = {"imu": ImuBlock}

    class Params(Params):
        axes: list[str] = param(["x", "y", "z"], description="device axis (with sign) that "
                                "becomes FLU x, y, z (toe, left, up); [x, -y, -z] for z-down "
                                "FRD devices (MAVLink, the real datasets); must be a rotation")
        accel_unit: Literal["m/s^2", "g"] = param("m/s^2", description="accel units of "
                                                  "ImuBlock inputs and text lines (CAN and "
                                                  "MAVLink frames carry their own)")
        gyro_unit: Literal["rad/s", "deg/s"] = param("rad/s", description="gyro units of "
                                                     "ImuBlock inputs and text lines")
        mag_unit: Literal["uT", "gauss", "nT"] = param("uT", description="magnetometer units "
                                                       "of ImuBlock inputs and text lines")
        calibration: str | None = param(None, description="per-device calibration YAML "
                                        "(docs/formats/calibration.md), relative to the "
                                        "pipeline file")
        accel_range: float = param(400.0, unit="m/s^2", gt=0, description="plausible limit "
                                   "per axis (about 40 g); samples beyond are dropped as corrupt")
        gyro_range: float = param(40.0, unit="rad/s", gt=0, description="plausible limit per "
                                  "axis (about 2300 deg/s); samples beyond are dropped")
        accel_saturation: float | None = param(None, unit="m/s^2", gt=0, description="the "
                                               "device's accel full scale: samples at or beyond "
                                               "are flagged saturated and kept")
        gyro_saturation: float | None = param(None, unit="rad/s", gt=0, description="the "
                                              "device's gyro full scale (flag, keep)")
        gap: float = param(0.05, unit="s", gt=0, description="a step between samples longer "
                           "than this is a gap: flagged gap_before, counted and reported")
        block_s: float = param(0.1, unit="s", gt=0, le=10, description="length of the blocks "
                               "samples decoded from frames are collected into")
        agent_map: dict[str, str] = param({}, description="frame device id (shell pattern, "
                                          "e.g. sys1/comp1/imu0 or can0/node*) -> 'agent' or "
                                          "'agent/device'; first match wins")
        default_agent: str = param("ff1", min_length=1, description="agent of frame devices "
                                   "that neither agent_map nor the frame's source names")
        dbc: str | None = param(None, description="DBC file of the CAN layout (default: the "
                                "shipped firenav_imu.dbc)")
        mavlink_messages: list[Literal["HIGHRES_IMU", "SCALED_IMU", "RAW_IMU"]] = param(
            ["HIGHRES_IMU", "SCALED_IMU", "RAW_IMU"], min_length=1,
            description="MAVLink messages used; list one if a device sends the same IMU as several")
        raw_accel_scale: float | None = param(None, unit="m/s^2", gt=0,
                                              description="RAW_IMU accel units per count")
        raw_gyro_scale: float | None = param(None, unit="rad/s", gt=0,
                                             description="RAW_IMU gyro units per count")
        raw_mag_scale: float | None = param(None, unit="uT", gt=0,
                                            description="RAW_IMU magnetometer units per count")
        clock_resync: float = param(1.0, unit="s", gt=0, description="a device clock step "
                                    "back (or leap ahead of the frame times) larger than this "
                                    "re-anchors it to the frame times")
        report_interval: float = param(10.0, unit="s", ge=0, description="at most one "
                                       "diagnostic per device and problem per this much data "
                                       "time; counts in between are summed")

        @field_validator("axes")
        @classmethod
        def _rotation(cls, axes: list[str]) -> list[str]:
            axes_matrix(axes)
            return axes

        @field_validator("agent_map")
        @classmethod
        def _targets(cls, mapping: dict[str, str]) -> dict[str, str]:
            for pattern, target in mapping.items():
                agent, slash, device = target.partition("/")
                if not agent or (slash and not device):
                    raise ValueError(f"agent_map '{pattern}': '{target}' must be 'agent' or "
                                     "'agent/device'")
            return mapping

        @model_validator(mode="after")
        def _saturation_in_range(self) -> "FootImuSensor.Params":
            for kind in ("accel", "gyro"):
                sat, rng = getattr(self, f"{kind}_saturation"), getattr(self, f"{kind}_range")
                if sat is not None and sat > rng:
                    raise ValueError(f"{kind}_saturation ({sat}) must not exceed "
                                     f"{kind}_range ({rng}): saturated samples would be dropped")
            return self

    def __init__(self, params: Params, ctx: Context):
        super().__init__(params, ctx)
        p = params
        self._R = axes_matrix(p.axes)
        self._scales = (UNIT_SCALES["accel_unit"][p.accel_unit],
                        UNIT_SCALES["gyro_unit"][p.gyro_unit],
                        UNIT_SCALES["mag_unit"][p.mag_unit])
        self._calibration: CalibrationFile | None = None
        if p.calibration:
            self._calibration = load_calibration(ctx.resolve(p.calibration))
        self._limits = QualityLimits(p.accel_range, p.gyro_range, p.accel_saturation,
                                     p.gyro_saturation, p.gap)
        lines = LineImuDecoder(*self._scales)
        self._decoders: dict[str, Any] = {
            "can": CanImuDecoder(ctx.resolve(p.dbc) if p.dbc else None,
                                 count=self._decoder_count),
            "mavlink": MavlinkImuDecoder(tuple(p.mavlink_messages), p.raw_accel_scale,
                                         p.raw_gyro_scale, p.raw_mag_scale),
            "serial": lines, "udp": lines,
        }
        self._reporter = _Reporter(ctx, p.report_interval)
        self._devices: dict[tuple[str, str], _Device] = {}
        self._routes: dict[str, tuple[_Device, DeviceClock]] = {}
        self._claimed: dict[str, str] = {}  # output device -> raw device id
        self._t = 0.0  # newest input time, for reports without one of their own
        self._warned_flu = False

    # -- inputs ---------------------------------------------------------------------
    def handle(self, stream: str, msg: Any) -> None:
        self._t = msg.t if np.isfinite(msg.t) else self._t
        if isinstance(msg, ImuBlock):
            self._block(msg)
        elif isinstance(msg, RawFrame):
            self._frame(msg)

    def _block(self, msg: ImuBlock) -> None:
        if msg.frame == "FLU" and not self._warned_flu and not np.array_equal(self._R, np.eye(3)):
            self._warned_flu = True
            self.ctx.diagnose(msg.t, "warning", "imu_already_flu",
                              f"{msg.device}: input is already FLU but `axes` "
                              f"{self.params.axes} rotates it again", agent=msg.agent)
        dev = self._device(msg.agent, msg.device, msg.device)
        sa, sg, sm = self._scales
        accel = msg.accel * sa if sa != 1 else msg.accel
        gyro = msg.gyro * sg if sg != 1 else msg.gyro
        mag = None if msg.mag is None else (msg.mag * sm if sm != 1 else msg.mag)
        flags = (np.zeros(len(msg), np.uint8) if msg.flags is None
                 else np.asarray(msg.flags, np.uint8))
        self._condition(dev, msg.t, _Samples(np.asarray(msg.time, float), accel, gyro, mag, flags))

    def _frame(self, frame: RawFrame) -> None:
        decoder = self._decoders.get(frame.transport)
        if decoder is None:
            self.ctx.count("frames_ignored")
            return
        try:
            samples = decoder.decode(frame)
        except FrameError as exc:
            self.ctx.count(exc.code)
            level, text = _FRAME_REPORTS[exc.code]
            self._reporter.report(frame.t, "", frame.device or frame.transport, exc.code, 1,
                                  f"{text}; latest: {exc}", level)
            return
        if samples is None:
            self.ctx.count("frames_ignored")
            return
        for s in samples:
            dev, clock = self._route(s.device, frame.agent)
            t, resynced = clock.to_pipeline(s.t, frame.t)
            if resynced:
                self._decoder_count("clock_resyncs", 1, dev)
            if (dev.buffer_t0 is not None and abs(t - dev.buffer_t0) >= self.params.block_s
                    or len(dev.buffer) >= _MAX_BUFFER):
                self._flush(dev)
            if dev.buffer_t0 is None and np.isfinite(t):
                dev.buffer_t0 = t
            dev.buffer.append((t, *s.accel, *s.gyro, *(s.mag or (np.nan,) * 3), s.flags))

    def _decoder_count(self, what: str, n: int, dev: _Device | None = None) -> None:
        self.ctx.count(what, n)
        level, text = _FRAME_REPORTS[what]
        self._reporter.report(self._t, dev.agent if dev else "", dev.device if dev else "",
                              what, n, text, level)

    def finish(self) -> None:
        self._decoders["can"].finish()
        for dev in list(self._devices.values()):
            self._flush(dev)
            if dev.held is not None:
                held, dev.held = dev.held, None
                self._condition(dev, self._t, held, final=True)
        self._reporter.flush()

    def reset(self, agent: str) -> None:
        self._devices = {k: d for k, d in self._devices.items() if d.agent != agent}
        self._routes = {k: r for k, r in self._routes.items() if r[0].agent != agent}
        self._claimed = {k: raw for k, raw in self._claimed.items() if raw in self._routes}

    # -- devices --------------------------------------------------------------------
    def _device(self, agent: str, device: str, raw_id: str) -> _Device:
        dev = self._devices.get((agent, device))
        if dev is not None:
            return dev
        cal = None
        if self._calibration is not None:
            cal = self._calibration.for_device(raw_id, device)
            if cal is None:
                self.ctx.diagnose(self._t, "info", "imu_uncalibrated",
                                  f"{device}: no entry in {self.params.calibration} and no "
                                  "default: used uncalibrated", agent=agent)
        dev = _Device(agent=agent, device=device,
                      accel=LinearCorrection.build(self._R, cal.accel if cal else None),
                      gyro=LinearCorrection.build(self._R, cal.gyro if cal else None),
                      mag=LinearCorrection.build(self._R, cal.mag if cal else None))
        self._devices[(agent, device)] = dev
        return dev

    def _route(self, raw_id: str, frame_agent: str) -> tuple[_Device, DeviceClock]:
        """The output stream and clock of a frame device.

        Its agent comes from ``agent_map``, else from the frame (a source that knows
        it), else ``default_agent``.
        """
        route = self._routes.get(raw_id)
        if route is not None:
            return route
        target = next((v for pattern, v in self.params.agent_map.items()
                       if fnmatch.fnmatchcase(raw_id, pattern)),
                      frame_agent or self.params.default_agent)
        agent, _, name = target.partition("/")
        device = target if name else f"{agent}/imu"
        other = self._claimed.get(device)
        if other is not None:
            renamed = f"{agent}/{raw_id}"
            self.ctx.diagnose(self._t, "warning", "imu_device_clash",
                              f"{raw_id} and {other} both map to {device}; {raw_id} is "
                              f"published as {renamed}: name each device in agent_map",
                              agent=agent)
            device = renamed
        self._claimed[device] = raw_id
        route = (self._device(agent, device, raw_id), DeviceClock(self.params.clock_resync))
        self._routes[raw_id] = route
        return route

    # -- conditioning ---------------------------------------------------------------
    def _flush(self, dev: _Device) -> None:
        if not dev.buffer:
            return
        rows = np.array(dev.buffer, dtype=float)
        dev.buffer, dev.buffer_t0 = [], None
        finite = rows[np.isfinite(rows[:, 0]), 0]
        mag = rows[:, 7:10]
        t_msg = float(finite.max()) if finite.size else self._t
        self._condition(dev, t_msg, _Samples(rows[:, 0], rows[:, 1:4], rows[:, 4:7],
                                             None if np.isnan(mag).all() else mag,
                                             rows[:, 10].astype(np.uint8)))

    def _condition(self, dev: _Device, t_msg: float, samples: _Samples,
                   final: bool = False) -> None:
        """Screen, correct and publish one device's samples (see the module docstring)."""
        if dev.held is not None:
            samples, dev.held = dev.held.then(samples), None
        if not final:
            samples, dev.held = _hold_leap(samples, dev.history.last_t, self.params.gap)
        if not len(samples):
            return
        result = screen(samples.time, samples.accel, samples.gyro, self._limits, dev.history,
                        samples.flags)
        for key, n in result.counts.items():
            if not n:
                continue
            what, text = _SCREEN_REPORTS[key]
            self.ctx.count(what, n)
            if text is not None:
                self._reporter.report(t_msg, dev.agent, dev.device, key, n, text,
                                      worst=result.longest_gap if key == "gaps" else 0.0)
        if not result.keep.any():
            return
        kept = samples.take(result.keep)
        block = ImuBlock(t=float(kept.time[-1]), agent=dev.agent, device=dev.device,
                         time=kept.time, accel=dev.accel(kept.accel), gyro=dev.gyro(kept.gyro),
                         mag=None if kept.mag is None else dev.mag(kept.mag),
                         flags=result.flags, frame="FLU")
        self.ctx.publish("imu", block)
        if not (dev.units_checked and dev.axes_checked):
            self._check_at_rest(dev, block)

    def _check_at_rest(self, dev: _Device, block: ImuBlock) -> None:
        """Once per device: does gravity read about +9.81 on z, and are the units right?"""
        if dev.first_t is None:
            dev.first_t = float(block.time[0])
        dev.window.append(np.hstack((block.accel, block.gyro)))
        data = np.concatenate(dev.window)
        span = float(block.t) - dev.first_t
        norm = np.linalg.norm(data[:, :3], axis=1)
        if not dev.units_checked and span >= 0.5:
            dev.units_checked = True
            med = float(np.median(norm))
            hint = ("accel_unit: g" if 0.5 < med < 2.0 else
                    "accel_unit: m/s^2" if 50.0 < med < 200.0 else None)
            if hint:
                self.ctx.diagnose(block.t, "warning", "imu_units_check",
                                  f"{dev.device}: median specific force is {med:.2f} in the "
                                  f"configured units (gravity should read 9.81 m/s^2): "
                                  f"check {hint}", agent=dev.agent)
        still = (np.abs(norm - GRAVITY) < 0.5) & (np.linalg.norm(data[:, 3:], axis=1) < 0.3)
        if not dev.axes_checked and still.sum() >= 20:
            dev.axes_checked = True
            z = float(data[still, 2].mean())
            if z < 0.5 * GRAVITY:
                self.ctx.diagnose(block.t, "warning", "imu_axes_check",
                                  f"{dev.device}: at rest gravity reads {z:+.2f} m/s^2 on FLU z "
                                  "(expected about +9.81): check `axes` (a z-down device "
                                  "needs [x, -y, -z]), unless the foot was upside down "
                                  "(crawling)", agent=dev.agent)
        if span >= _CHECK_WINDOW_S:
            dev.units_checked = dev.axes_checked = True
        if dev.units_checked and dev.axes_checked:
            dev.window = []


def _hold_leap(samples: _Samples, last_t: float, gap: float
               ) -> tuple[_Samples, _Samples | None]:
    """Split off a last sample that leaps more than ``gap`` ahead of its predecessor.

    Only the sample after it can tell a real gap from a corrupt timestamp (see
    ``time_outlier`` in :mod:`.imu_quality`), so it waits for the device's next input.
    """
    t = samples.time
    if not len(t) or not np.isfinite(t[-1]):
        return samples, None
    before = t[:-1][np.isfinite(t[:-1])]
    prev = before[-1] if before.size else last_t
    if np.isfinite(prev) and t[-1] - prev > gap:
        return samples.take(slice(0, -1)), samples.take(slice(-1, None))
    return samples, None


PLUGINS = [FootImuSensor]
