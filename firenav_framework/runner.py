"""Builds a validated pipeline and runs it: sources -> timeline -> bus -> components.

Offline sources are merged lazily (always pulling from the source whose next message
is oldest) and replayed as fast as possible, or paced to the wall clock with
``realtime``. Live sources run in their own threads and feed a queue; the timeline
then also releases any message that has waited ``reorder_window`` seconds of wall
time, which bounds latency. Both paths go through the same timeline, bus and
components.
"""
from __future__ import annotations

import gc
import heapq
import logging
import math
import os
import queue
import signal
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TextIO

from .bus import Bus, Fault, Subscription
from .contract import Component, Context, Estimator, Source
from .contract.context import PIPELINE_DIR, NoBuilding
from .execution import AgentLanes, Backpressure, lane_components
from .messages import Diagnostic, Message
from .pipeline import PipelineSpec
from .stats import RunStats
from .timefmt import clock_text
from .time_merge import merge_in_time
from .timeline import Timeline
from .tracks import Track, TrackStore
from .watchdog import Watchdog

log = logging.getLogger("firenav.runner")


@contextmanager
def frozen_heap() -> Iterator[None]:
    """Keep every object that exists now out of the garbage collector's full passes
    for the block, collectable again after it (many runs share a test process).

    A run's start-up (plugins, plans, loaded recordings, imported libraries: about
    200 000 objects in a kit's process) lives for the whole run; a full pass walks all
    of it, holding the interpreter, and so every thread, for ~120 ms on a 2-core
    machine, several times a minute under load. Frozen, a full pass walks only what
    the run itself made (a few ms).
    """
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()


def blas_threads() -> int:
    """BLAS threads during a run: ``$FIRENAV_BLAS_THREADS``, else 1.

    The estimators' matrices are small (tens to hundreds of rows), where BLAS threads
    cost more than they give, above all on a busy 2-core field kit.
    """
    try:
        return max(1, int(os.environ.get("FIRENAV_BLAS_THREADS", "1")))
    except ValueError:
        return 1


class PipelineBuildError(RuntimeError):
    """A component could not be constructed (bad file, missing device ...)."""


@dataclass
class RunResult:
    """Everything a run produced, for the summary, evaluation and tests."""

    pipeline: str
    stats: RunStats
    tracks: dict[str, dict[str, Track]]
    truth: dict[str, Track]
    diagnostics: list[Diagnostic]
    faults: list[Fault]
    t_first: float | None
    t_last: float | None
    wall_s: float
    components: dict[str, Component] = field(default_factory=dict)
    building: Any = None

    @property
    def duration_s(self) -> float:
        return 0.0 if self.t_first is None else self.t_last - self.t_first


class _Progress:
    """Prints a progress line to stderr every few seconds of wall time."""

    def __init__(self, span: tuple[float, float] | None, stream: TextIO | None, every: float = 2.0):
        self.span, self.stream, self.every = span, stream, every
        self.start = time.monotonic()
        self.next = self.start + every
        self.count = 0

    def update(self, t: float) -> None:
        self.count += 1
        if self.stream is None or (self.count & 255 and self.every > 0):
            return
        now = time.monotonic()
        if now < self.next:
            return
        self.next = now + self.every
        line = f"[firenav] {clock_text(t)}"  # a live link's clock as the local time
        if self.span and self.span[1] > self.span[0]:
            frac = min(1.0, max(0.0, (t - self.span[0]) / (self.span[1] - self.span[0])))
            line += f" of {self.span[1] - self.span[0]:.0f} s ({100 * frac:.0f}%)"
        line += f", {self.count} messages, {now - self.start:.0f} s elapsed"
        print(line, file=self.stream, flush=True)


class Runner:
    """One run of one pipeline. Create, then call :meth:`run` once."""

    def __init__(self, spec: PipelineSpec, *, output_dir: Path | None = None,
                 realtime: bool = False, speed: float = 1.0,
                 progress: TextIO | None = None, progress_every: float = 2.0,
                 workers: int = 0, backpressure: bool = True, hard_exit: bool = False):
        """``workers``: threads for the per-firefighter work of components that allow it
        (0: none); ``backpressure``: in live runs, degrade firefighters while the kit is
        behind (:mod:`.execution`); ``hard_exit``: see :mod:`.watchdog`."""
        self.spec = spec
        self.output_dir = output_dir
        self.realtime = realtime
        self.speed = speed
        self.progress_stream = progress
        self.progress_every = progress_every
        self.stats = RunStats()
        #: times every plugin call; ``hard_exit``: end the process when native code hangs
        self.watchdog = Watchdog(hard_exit=hard_exit)
        self.bus = Bus(stats=self.stats, watchdog=self.watchdog)
        self.timeline = Timeline(spec.timeline, self.stats)
        self.store = TrackStore()
        self.diagnostics: list[Diagnostic] = []
        self.components: dict[str, Component] = {}
        self.subs: dict[str, Subscription] = {}
        self._stop = threading.Event()
        self._building_cache: list[Any] = []
        self._tick_streams: set[str] = set()
        self.workers = workers              # threads for per-firefighter work (0: none)
        self.use_backpressure = backpressure
        self.lanes: AgentLanes | None = None
        self.backpressure: Backpressure | None = None
        self._relabels: set[tuple[str, str]] = set()

    # -- construction ---------------------------------------------------------------
    def _load_building(self) -> Any:
        if not self._building_cache:
            if self.spec.building is not None:
                from .building import BuildingError, load_building
                try:
                    self._building_cache.append(load_building(self.spec.building))
                except BuildingError as exc:
                    where = f"{self.spec.file}:{self.spec.document.locate(('building',))[0]}"
                    raise PipelineBuildError(f"{where}: building: {exc}") from None
            else:
                for comp in self.components.values():
                    if isinstance(comp, Source) and comp.building() is not None:
                        self._building_cache.append(comp.building())
                        break
                else:
                    raise NoBuilding("this pipeline has no building")
        return self._building_cache[0]

    def _check_plans(self) -> None:
        """Warn when the pipeline's ``building:`` and a source's own plan (a simulator
        scenario's) are different plans: the map-aided plugins use the pipeline's."""
        if self.spec.building is None:
            return
        mine = Path(self.spec.building).resolve()
        for cid, comp in self.components.items():
            other = comp.building() if isinstance(comp, Source) else None
            theirs = getattr(other, "source", None)
            if theirs is None or Path(theirs).resolve() == mine or _same_bytes(mine, Path(theirs)):
                continue
            text = (f"the pipeline's building {self.spec.building} is not the plan source "
                    f"'{cid}' brings ({theirs}): map-aided plugins use the pipeline's, while "
                    f"'{cid}' moves in its own; remove one of them if that is not meant")
            log.warning(text)
            self.diagnostics.append(Diagnostic(t=0.0, component="runner", level="warning",
                                               code="plan_mismatch", text=text))

    def _publish(self, cid: str, port: str, msg: Message) -> None:
        spec = self._specs[cid]
        if port not in spec.outputs:
            raise ValueError(f"'{cid}' ({spec.plugin.name}) published on undeclared port "
                             f"'{port}'; its ports are {', '.join(spec.outputs)}")
        if msg.agent and spec.kind != "source" and not isinstance(msg, Diagnostic):
            received = self.subs[cid].received
            owner = msg.device.partition("/")[0] if "/" in msg.device else ""
            if received and (msg.agent not in received or (
                    owner and owner != msg.agent and owner in received)):
                self._relabelled(cid, msg, received)
        self.bus.publish(f"{cid}.{port}", msg)

    def _relabelled(self, cid: str, msg: Message, received: set[str]) -> None:
        """A component published for an agent it never received data of, or published
        another agent's device under this agent: say so once (and count every time)."""
        self.stats.count(cid, "agent_relabelled")
        if (cid, msg.agent) in self._relabels:
            return
        self._relabels.add((cid, msg.agent))
        what = (f"device '{msg.device}' of another firefighter" if msg.agent in received
                else f"data only of {', '.join(sorted(received))}")
        text = (f"'{cid}' published a {type(msg).__name__} of agent '{msg.agent}' but has "
                f"received {what}: it relabels agents (expected only where its parameters "
                "map devices to agents)")
        log.warning(text)
        self.diagnostics.append(Diagnostic(t=msg.t, agent=msg.agent, component="runner",
                                           level="warning", code="agent_relabelled", text=text))

    def build(self) -> None:
        self._specs = {c.id: c for c in self.spec.components}
        out_dir = self.output_dir
        for cs in self.spec.components:
            ctx = Context(cs.id, stats=self.stats, publish=self._publish,
                          base_dir=self.spec.base_dir, output_dir=out_dir,
                          building_loader=self._load_building)
            try:
                comp = cs.cls(cs.params, ctx)
            except Exception as exc:
                where = f"{self.spec.file}:{self.spec.document.locate(cs.path)[0]}"
                raise PipelineBuildError(f"{where}: cannot set up '{cs.id}' "
                                         f"({cs.plugin.name}): {exc}") from exc
            self.components[cs.id] = comp
            sub = Subscription(comp, policy=cs.on_error, agents=cs.agents,  # type: ignore[arg-type]
                               watchdog=cs.watchdog)
            self.subs[cs.id] = sub
            for stream in cs.inputs:
                self.bus.subscribe(stream, sub)
            period = cs.cls.tick_period(cs.params)
            if period:
                stream = f"ticks.{period:g}"
                if stream not in self._tick_streams:
                    self._tick_streams.add(stream)
                    self.timeline.add_tick(period, stream)
                self.bus.subscribe(stream, sub)
        self._check_plans()
        for cs in self.spec.components:
            if cs.kind == "constraint":
                parent = self.components[cs.parent]
                assert isinstance(parent, Estimator)
                parent.constraints.append(self.components[cs.id])
        self.bus.taps.append(self.store)
        self.bus.taps.append(self._tap_diagnostics)
        self._setup_execution()

    def _setup_execution(self) -> None:
        """Worker lanes for per-firefighter work and the live backpressure (execution.py)."""
        if self.workers:
            self.lanes = AgentLanes(self.bus, self._publish, self.workers)
            self.lanes.install(self.subs, lane_components(self.components),
                               {cs.id: tuple(cs.inputs) for cs in self.spec.components})
        live = any(isinstance(c, Source) and c.live for c in self.components.values())
        if self.use_backpressure and live:
            bp = self.backpressure = Backpressure(
                self.components, lambda d: self.bus.publish("runner.diagnostics", d))
            if bp.components:
                self.bus.taps.append(lambda stream, msg: bp.saw(msg.agent))

    def _tap_diagnostics(self, stream: str, msg: Message) -> None:
        if isinstance(msg, Diagnostic):
            self.diagnostics.append(msg)

    # -- running ------------------------------------------------------------------
    def stop(self) -> None:
        """Ask the run to end (e.g. on Ctrl-C): sources stop, buffers are flushed."""
        self._stop.set()
        for comp in self.components.values():
            if isinstance(comp, Source):
                comp.stop()

    def run(self) -> RunResult:
        from threadpoolctl import threadpool_limits
        token = PIPELINE_DIR.set(self.spec.base_dir)
        limits = [c.watchdog for c in self.spec.components if c.watchdog]
        self.watchdog.start(max(limits, default=0.0))
        saved = {}
        if threading.current_thread() is threading.main_thread():
            saved = {sig: signal.signal(sig, self._on_stop_signal)
                     for sig in (signal.SIGTERM, signal.SIGINT)}
        try:
            with threadpool_limits(limits=blas_threads(), user_api="blas"):
                return self._run()
        finally:
            self.watchdog.stop()
            for sig, handler in saved.items():
                signal.signal(sig, handler)
            PIPELINE_DIR.reset(token)

    def _on_stop_signal(self, signum: int, frame: Any) -> None:
        """SIGTERM or Ctrl-C: end the run cleanly (sources stop, what arrived is used,
        every plugin finishes); a plugin call that does not return within
        ``STOP_GRACE_S`` is cut short. A second Ctrl-C aborts at once."""
        if signum == signal.SIGINT and self._stop.is_set():
            self.watchdog.user_interrupt = True
            raise KeyboardInterrupt
        log.warning("%s: stopping the run (flushing what has arrived)",
                    signal.Signals(signum).name)
        self.stop()
        self.watchdog.hurry()

    def _building_if_any(self) -> Any:
        try:
            return self._load_building()
        except NoBuilding:
            return None

    def _run(self) -> RunResult:
        self.build()
        wall0 = time.monotonic()
        for cid, comp in self.components.items():
            self.bus.call(self.subs[cid], "start", comp.start)
        sources = [(cid, c) for cid, c in self.components.items() if isinstance(c, Source)]
        spans = [s.duration() for _, s in sources]
        span = None if any(sp is None for sp in spans) or not spans else (
            min(sp[0] for sp in spans), max(sp[1] for sp in spans))
        progress = _Progress(span, self.progress_stream, self.progress_every)
        self._t_first: float | None = None
        self._t_last: float | None = None
        self._pace0: tuple[float, float] | None = None
        try:
            with frozen_heap():
                if any(s.live for _, s in sources):
                    self._run_live(sources, progress)
                else:
                    self._run_offline(sources, progress)
        except KeyboardInterrupt:  # a second Ctrl-C (see _on_stop_signal): abort
            self.stop()
            raise
        for cid, comp in self.components.items():
            if self.lanes is not None:   # what the workers hold goes out before finish
                self.lanes.sync()
            if not isinstance(comp, Source):
                self.bus.call(self.subs[cid], "finish", comp.finish,
                              t=self._t_last if self._t_last is not None else 0.0)
            comp.ctx.flush_reports()
        if self.lanes is not None:
            self.lanes.close()
        return RunResult(
            pipeline=self.spec.name, stats=self.stats, tracks=self.store.tracks(),
            truth=self.store.truth(), diagnostics=self.diagnostics, faults=self.bus.faults,
            t_first=self._t_first, t_last=self._t_last, wall_s=time.monotonic() - wall0,
            components=self.components, building=self._building_if_any())

    def _source_iter(self, cid: str, src: Source, timed: bool = True
                     ) -> Iterator[tuple[str, Message]]:
        """A source's messages as (stream, message); a failing source is a contained fault.
        ``timed``: each next message is a watchdog-timed call (not for live sources,
        which block in their own threads by design)."""
        it = src.messages()
        sub, wd = self.subs[cid], self.watchdog
        while True:
            try:
                if timed:
                    wd.enter(cid, sub.watchdog, "messages")
                try:
                    port, msg = next(it)
                finally:
                    if timed:
                        wd.leave()
            except StopIteration:
                return
            except BaseException as exc:
                if sub.policy == "raise" or not self.bus.contained(exc):
                    raise
                self.bus.report_fault(sub, f"{cid}.messages",
                                      Diagnostic(t=self._t_last or 0.0, component=cid, level="",
                                                 code="", text=""), exc)
                return
            yield f"{cid}.{port}", msg

    def _run_offline(self, sources: list[tuple[str, Source]], progress: _Progress) -> None:
        cfg = self.spec.timeline
        merged = merge_in_time([self._source_iter(cid, src) for cid, src in sources],
                               time_of=lambda item: item[1].t, max_lead=cfg.max_lead,
                               jump_back=max(cfg.clock_jump, cfg.reorder_window))
        for stream, msg in merged:
            self.timeline.push(stream, msg)
            self._dispatch(self.timeline.release(), progress)
            if self._stop.is_set():
                break
        self._dispatch(self.timeline.release(flush=True), progress)

    def _run_live(self, sources: list[tuple[str, Source]], progress: _Progress) -> None:
        q: queue.Queue = queue.Queue()
        done = object()

        def pump(cid: str, src: Source) -> None:
            try:
                for item in self._source_iter(cid, src, timed=False):
                    q.put((time.monotonic(), item))
                    if self._stop.is_set():
                        break
            finally:
                q.put((time.monotonic(), done))

        threads = [threading.Thread(target=pump, args=s, name=f"source-{s[0]}", daemon=True)
                   for s in sources]
        for th in threads:
            th.start()
        running = len(threads)
        window = self.spec.timeline.reorder_window
        arrivals: list[tuple[float, float]] = []  # (wall arrival, t) min-heap by arrival
        while running:
            try:
                wall, item = q.get(timeout=max(0.01, window / 4))
            except queue.Empty:
                item = None
            else:
                if item is done:
                    running -= 1
                else:
                    stream, msg = item
                    self.timeline.push(stream, msg)
                    heapq.heappush(arrivals, (wall, msg.t))
                    self._note_wait(msg, wall)
            now = time.monotonic()
            older = -math.inf
            while arrivals and arrivals[0][0] + window <= now:
                older = max(older, heapq.heappop(arrivals)[1])
            self._dispatch(self.timeline.release(older_than=older), progress)
            if self.lanes is not None:
                self.lanes.sync()
        self._dispatch(self.timeline.release(flush=True), progress)

    def _note_wait(self, msg: Message, arrived: float) -> None:
        """Tell the backpressure how long a live message queued before the pipeline took it."""
        if self.backpressure is not None:
            self.backpressure.observe(time.monotonic() - arrived, time.monotonic(), msg.t)

    def _dispatch(self, released: list[tuple[str, Message]], progress: _Progress) -> None:
        for stream, msg in released:
            if self._t_first is None:
                self._t_first = msg.t
            self._t_last = msg.t if self._t_last is None else max(self._t_last, msg.t)
            if self.realtime:
                self._pace(msg.t)
            self.bus.publish(stream, msg)
            if self.lanes is not None:
                self.lanes.dispatched_one()
            progress.update(msg.t)

    def _pace(self, t: float) -> None:
        if self._pace0 is None:
            self._pace0 = (time.monotonic(), t)
            return
        wall0, t0 = self._pace0
        delay = wall0 + (t - t0) / self.speed - time.monotonic()
        if delay > 0:
            time.sleep(delay)


def _same_bytes(a: Path, b: Path) -> bool:
    try:
        return a.read_bytes() == b.read_bytes()
    except OSError:
        return False


def run_pipeline(spec: PipelineSpec, **kw: Any) -> RunResult:
    """Build and run ``spec`` (see :class:`Runner` for the keywords)."""
    return Runner(spec, **kw).run()
