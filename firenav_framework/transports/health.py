"""Link health: per-device frame rate, gaps, decode errors and silence.

A :class:`LinkMonitor` is told about every frame (``frame(key, t)``) and every frame
it could not use (``decode_error``), and asked at regular moments
(``check(now)``) what the commander must know. Times are receive times in seconds
on one clock (see :mod:`.clock`); the monitor never reads a clock itself, so the
same frames fed at the same times give the same diagnostics (tests, replays).

Keys name a device stream, e.g. ``can0/0x110`` or ``sys3/comp1/HIGHRES_IMU``; the
``agents`` mapping (shell-style patterns -> firefighter id) lets a silence
diagnostic name the firefighter whose track goes stale.

Diagnostics (all with ``component`` = the source id):

``device_silent`` (error)
    no frame from a device for ``silent_after`` seconds; the same code with
    ``active=False`` (info) when it is heard again.
``link_gap`` (warning)
    a device resumed after a pause longer than ``gap_factor`` times its usual
    interval (and at least ``min_gap`` seconds) but shorter than ``silent_after``.
``link_health`` (info)
    every ``report_every`` seconds: rate, frames, gaps and decode errors per device.
"""
from __future__ import annotations

import fnmatch
from dataclasses import dataclass

from ..messages import Diagnostic


@dataclass
class DeviceHealth:
    """What the monitor knows about one device stream (times in receive seconds)."""

    key: str
    agent: str
    first_t: float
    last_t: float
    frames: int = 0
    gaps: int = 0
    interval: float = 0.0  # smoothed interval between frames [s]
    silent: bool = False
    silent_since: float = 0.0

    @property
    def rate_hz(self) -> float:
        """Smoothed frame rate [Hz] (0 before two frames arrived)."""
        return 1.0 / self.interval if self.interval > 0 else 0.0


class LinkMonitor:
    """Tracks the health of every device heard on one link."""

    def __init__(self, component: str, *, silent_after: float = 2.0, gap_factor: float = 5.0,
                 min_gap: float = 0.1, report_every: float = 10.0,
                 agents: dict[str, str] | None = None):
        if silent_after <= 0:
            raise ValueError(f"silent_after must be positive, got {silent_after}")
        self.component = component
        self.silent_after = silent_after
        self.gap_factor = gap_factor
        self.min_gap = min_gap
        self.report_every = report_every
        self.agents = dict(agents or {})
        self.devices: dict[str, DeviceHealth] = {}
        self.decode_errors: dict[str, int] = {}
        self._pending: list[Diagnostic] = []
        self._next_report: float | None = None

    def agent_of(self, key: str) -> str:
        """The firefighter a device key belongs to ('' when no pattern matches)."""
        for pattern, agent in self.agents.items():
            if fnmatch.fnmatchcase(key, pattern):
                return agent
        return ""

    def frame(self, key: str, t: float) -> None:
        """One frame from device ``key`` received at ``t`` [s]."""
        dev = self.devices.get(key)
        if dev is None:
            self.devices[key] = DeviceHealth(key, self.agent_of(key), t, t, frames=1)
            return
        dt = t - dev.last_t
        if dev.silent:
            dev.silent = False
            self._pending.append(self._diag(t, dev, "info", "device_silent",
                                            f"{self._name(dev)} is heard again after "
                                            f"{t - dev.last_t:.1f} s of silence", active=False))
        elif dev.interval > 0 and dt > max(self.gap_factor * dev.interval, self.min_gap):
            dev.gaps += 1
            self._pending.append(self._diag(t, dev, "warning", "link_gap",
                                            f"{self._name(dev)}: {dt:.2f} s without frames "
                                            f"(usually {dev.interval * 1e3:.1f} ms)"))
        elif dt > 0:
            dev.interval = dt if dev.interval == 0 else 0.95 * dev.interval + 0.05 * dt
        dev.last_t = t
        dev.frames += 1

    def decode_error(self, key: str, n: int = 1) -> None:
        """``n`` frames from ``key`` that could not be parsed (bad CRC, garbage, error frame)."""
        self.decode_errors[key] = self.decode_errors.get(key, 0) + n

    def check(self, now: float) -> list[Diagnostic]:
        """Diagnostics due at receive time ``now``: silences, come-backs, gaps, reports."""
        out, self._pending = self._pending, []
        for dev in self.devices.values():
            if not dev.silent and now - dev.last_t >= self.silent_after:
                dev.silent, dev.silent_since = True, now
                out.append(self._diag(now, dev, "error", "device_silent",
                                      f"{self._name(dev)}: no frames for "
                                      f"{now - dev.last_t:.1f} s (last rate "
                                      f"{dev.rate_hz:.1f} Hz); its track is stale"))
        if self.report_every > 0 and self.devices:
            if self._next_report is None:
                self._next_report = now + self.report_every
            elif now >= self._next_report:
                self._next_report = now + self.report_every
                out.append(Diagnostic(t=now, component=self.component, level="info",
                                      code="link_health", text=self.report()))
        return out

    def report(self) -> str:
        """One line per device: rate, frames, gaps, state; then decode errors."""
        parts = [f"{d.key}{' (' + d.agent + ')' if d.agent else ''}: {d.rate_hz:.1f} Hz, "
                 f"{d.frames} frames, {d.gaps} gaps{', SILENT' if d.silent else ''}"
                 for d in sorted(self.devices.values(), key=lambda d: d.key)]
        parts += [f"{k}: {n} decode errors" for k, n in sorted(self.decode_errors.items())]
        return "; ".join(parts) or "no devices heard"

    def _name(self, dev: DeviceHealth) -> str:
        return f"{dev.key} ({dev.agent})" if dev.agent else dev.key

    def _diag(self, t: float, dev: DeviceHealth, level: str, code: str, text: str, *,
              active: bool = True) -> Diagnostic:
        return Diagnostic(t=t, agent=dev.agent, device=dev.key, component=self.component,
                          level=level, code=code, text=text, active=active)
