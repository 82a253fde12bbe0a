"""The base of every live source: a link, its raw recorder and its health monitor.

:meth:`LiveSource.messages` runs in the runner's source thread. For every arrival it
first records the native frames of a read and hands them to the operating system
(before anything can go wrong with them, and before the pipeline sees them: a
process killed with ``kill -9`` has logged every frame it used, so the replay of its
logs reproduces every pose it published), then updates the link health and yields
``("raw", RawFrame)`` per frame. Between reads it yields the health diagnostics that
are due and lets the recorder rotate. A link that fails to open or
breaks is reported (``link_down``), retried every ``reconnect_s`` seconds, and
reported again when it is back (``link_down`` with ``active=False``).

Recordings go to ``<output>/<record_dir>/<source id>/`` so that ``firenav replay``
can give each source its own files back.
"""
from __future__ import annotations

import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any, ClassVar

from ..contract import OutputName, Params, Source, param
from ..messages import Diagnostic, Message, RawFrame
from . import clock
from .health import LinkMonitor
from .links import Link, LinkLost
from .recorders import RotatingRecorder

#: How long one read waits [s]: bounds the reaction time to stop() and silence.
POLL_S = 0.1


class LiveParams(Params):
    """Parameters every live source has: recording, health and reconnection."""

    record: bool = param(True)
    """write every frame to disk as it arrives, before decoding (turn off only for throw-away
    tests)"""
    record_dir: OutputName = param("raw")
    """folder for the recordings, under the output folder; each source writes into
    <record_dir>/<id>/"""
    rotate_mb: float = param(64.0, unit="MiB", gt=0)
    """start a new log file when the current one reaches this size"""
    rotate_min: float = param(60.0, unit="min", ge=0)
    """start a new log file after this many minutes (0: only by size)"""
    silent_after: float = param(2.0, unit="s", gt=0)
    """a device heard before and silent this long raises device_silent"""
    report_every: float = param(10.0, unit="s", ge=0)
    """link_health report period (0: never)"""
    device_agents: dict[str, str] = param({})
    """device-key pattern -> firefighter id, so silence diagnostics name the firefighter whose
    track goes stale (e.g. {'sys1/*': ff1, 'can0/0x11?': ff1})"""
    reconnect_s: float = param(1.0, unit="s", gt=0)
    """retry period while the link is down"""
    idle_exit_s: float = param(0.0, unit="s", ge=0)
    """end the source after this long without any frame once frames have arrived (0: run until
    stopped)"""


class LiveSource(Source):
    """Common machinery of the live sources (not a plugin itself)."""

    live = True
    outputs = {"raw": RawFrame}
    Params: ClassVar[type[Params]] = LiveParams

    def __init__(self, params: Params, ctx: Any):
        super().__init__(params, ctx)
        self._stopping = threading.Event()
        self.link = self.make_link()
        self.recorder: RotatingRecorder | None = None
        self._record_failed = False
        self.monitor = LinkMonitor(ctx.id, silent_after=params.silent_after,
                                   report_every=params.report_every, agents=params.device_agents)

    # -- what a transport provides ------------------------------------------------------
    def make_link(self) -> Link:
        raise NotImplementedError

    def make_recorder(self, folder: Path, **kw: Any) -> RotatingRecorder:
        raise NotImplementedError

    # -- the loop -----------------------------------------------------------------------
    def record_folder(self) -> Path:
        return (self.ctx.output_dir or Path("out")) / self.params.record_dir / self.ctx.id

    def stop(self) -> None:
        self._stopping.set()

    def messages(self) -> Iterator[tuple[str, Message]]:
        p = self.params
        if p.record:
            self.recorder = self.make_recorder(
                self.record_folder(), rotate_bytes=int(p.rotate_mb * (1 << 20)),
                rotate_s=p.rotate_min * 60.0)
        up: bool | None = None  # None: never connected yet
        last_frame: float | None = None
        try:
            while not self._stopping.is_set():
                if not up:
                    up, diag = self._connect(up)
                    if diag is not None:
                        yield "diagnostics", diag
                    if not up:
                        self._stopping.wait(p.reconnect_s)
                        continue
                try:
                    arrivals = self.link.read(POLL_S)
                except LinkLost as exc:
                    self.link.close()
                    up = False
                    self.ctx.count("link_lost")
                    yield "diagnostics", self._link_diag("error", f"link lost: {exc}", True)
                    continue
                if self.recorder is not None and arrivals:
                    failure = self._record(arrivals)
                    if failure is not None:
                        yield "diagnostics", failure
                for t_us, native in arrivals:
                    frame = self.link.to_frame(t_us, native)
                    if frame is None:
                        self.monitor.decode_error(self.link.health_key(native))
                        self.ctx.count("decode_errors")
                        continue
                    self.monitor.frame(self.link.health_key(native), frame.t)
                    last_frame = frame.t
                    yield "raw", frame
                if arrivals:
                    self.ctx.count("frames", len(arrivals))
                now = clock.now()
                for diag in self.monitor.check(now):
                    yield "diagnostics", diag
                if self.recorder is not None:
                    self.recorder.poll()
                if p.idle_exit_s and last_frame is not None and now - last_frame >= p.idle_exit_s:
                    break
        finally:
            self.link.close()
            if self.recorder is not None:
                self.recorder.close()

    def _record(self, arrivals: list[tuple[int, Any]]) -> Diagnostic | None:
        """Write a batch and hand it to the operating system before any of its frames
        is passed on: a killed process has logged every frame its pipeline saw.

        A recorder that fails (disk full, a frame its format cannot hold) does not stop
        the link: the frames still go on, each unrecorded one is counted, and the first
        failure of a run is reported.
        """
        written = 0
        try:
            for t_us, native in arrivals:
                item = self.link.record_item(native)
                if item is not None:
                    self.recorder.write(t_us, item)
                written += 1
            self.recorder.flush()
            return None
        except Exception as exc:  # noqa: BLE001 - any writer error; the link must go on
            # a failed flush may have lost the whole batch
            self.ctx.count("frames_not_recorded", (len(arrivals) - written) or len(arrivals))
            if self._record_failed:
                return None
            self._record_failed = True
            return Diagnostic(t=clock.now(), component=self.ctx.id, level="error",
                              code="recording_failed",
                              text=f"{self.ctx.id}: recording failed ({type(exc).__name__}: "
                                   f"{exc}); frames are still passed on", active=True)

    def _connect(self, was_up: bool | None) -> tuple[bool, Diagnostic | None]:
        try:
            self.link.open()
        except Exception as exc:
            if was_up is not False:  # report the first failure, not every retry
                self.ctx.count("link_open_failed")
                return False, self._link_diag("error", f"cannot open: {type(exc).__name__}: "
                                              f"{exc}; retrying every {self.params.reconnect_s:g} s",
                                              True)
            return False, None
        if was_up is False:
            return True, self._link_diag("info", "link is back", False)
        return True, None

    def _link_diag(self, level: str, text: str, active: bool) -> Diagnostic:
        return Diagnostic(t=clock.now(), component=self.ctx.id, level=level, code="link_down",
                          text=f"{self.ctx.id} ({self.link.transport}): {text}", active=active)
