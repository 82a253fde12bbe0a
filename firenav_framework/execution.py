"""How the runner uses the machine: per-firefighter worker threads, and backpressure.

:class:`AgentLanes` runs the per-firefighter work of chosen components on worker
threads. A component qualifies when its class says ``agents_independent = True``: what
it does with one firefighter's messages depends on nothing of another's (it keeps its
state in :class:`~firenav_framework.contract.PerAgent`). Its numba kernels compiled with
``nogil=True`` then run on both cores at once. Order and determinism are kept:

* every message of one firefighter for one component goes to the same worker, in
  delivery order, so each firefighter sees exactly the serial sequence;
* what a worker's component publishes is held, and published on the pipeline thread
  at the next :meth:`AgentLanes.commit`, in the order of the inputs that caused it;
* a commit happens before any message reaches a component that reads a lane
  component's output (so those still see time order), before a message without a
  firefighter (a tick) reaches a lane component, at the end of every batch the
  timeline releases in a live run, every :data:`COMMIT_EVERY` messages in a replay
  (a fixed count: the same points in every replay), and before ``finish``;
* an exception in a worker is reported on the pipeline thread at the commit, under the
  component's fault policy, as if it had been raised there; what the worker did with
  that firefighter's later messages of the same commit is discarded (and counted
  ``skipped_after_fault``), as the serial bus would not have delivered them.

A replay therefore publishes the same messages in the same order whatever the thread
timing, and each firefighter's track equals the serial run's. A lane component's
counters and rate-limited reports (``ctx.count``, ``ctx.report``) are updated from its
workers: one dictionary entry per call, under the GIL.

:class:`Backpressure` watches how long released messages waited in a live run. When
the kit falls behind by more than ``behind_s`` (the CPU cannot keep up, e.g. another
process holds a core), it moves one firefighter at a time to a cheaper mode, through
the optional component hook ``degrade(agent, level) -> str | None`` (level 0 normal, 1
cheaper; the text says what changed), and reports each step as a ``degraded``
diagnostic; once the wait has stayed below ``caught_up_s`` for ``hold_s`` it restores
them in reverse order (``restored``). Every frame is still recorded by its source
before anything else and still processed: only how finely is changed.
"""
from __future__ import annotations

import threading
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

from .bus import Bus, Subscription
from .contract import Component
from .messages import Diagnostic, Message

__all__ = ["AgentLanes", "Backpressure", "COMMIT_EVERY", "lane_components"]

#: Messages dispatched between two commits of a replay.
COMMIT_EVERY = 256

_local = threading.local()   # the task a worker thread is running, if any


def lane_components(components: dict[str, Component]) -> list[str]:
    """Ids of the components whose classes declare ``agents_independent = True``."""
    return [cid for cid, c in components.items()
            if getattr(type(c), "agents_independent", False)]


@dataclass
class _Task:
    component: Component
    proxy: "_LaneProxy"
    stream: str
    msg: Message
    outputs: list[tuple[str, str, Message]] = field(default_factory=list)
    error: BaseException | None = None


class _Worker(threading.Thread):
    def __init__(self, lanes: "AgentLanes", index: int):
        super().__init__(name=f"lane-{index}", daemon=True)
        self.lanes = lanes
        self.tasks: list[_Task | None] = []
        self.ready = threading.Condition(threading.Lock())

    def submit(self, task: _Task | None) -> None:
        with self.ready:
            self.tasks.append(task)
            self.ready.notify()

    def run(self) -> None:
        while True:
            with self.ready:
                while not self.tasks:
                    self.ready.wait()
                batch, self.tasks = self.tasks, []
            for task in batch:
                if task is None:
                    return
                _local.task = task
                try:
                    task.component.handle(task.stream, task.msg)
                except BaseException as exc:  # noqa: BLE001 - handed to the bus at commit
                    task.error = exc
                finally:
                    _local.task = None
                self.lanes._done()


class _LaneProxy:
    """Stands in for a lane component in its bus subscription: hands messages of a
    firefighter to that firefighter's worker, and runs the others inline after a commit."""

    def __init__(self, lanes: "AgentLanes", sub: Subscription):
        self.lanes = lanes
        self.sub = sub
        self.component = sub.component
        self.ctx = sub.component.ctx

    def handle(self, stream: str, msg: Message) -> None:
        if not msg.agent:
            self.lanes.commit()
            self.component.handle(stream, msg)
            return
        self.lanes.submit(self, stream, msg)

    def reset(self, agent: str) -> None:
        self.lanes.commit()
        self.component.reset(agent)


class _AfterCommit:
    """Stands in for a component that reads a lane component's output: commits first."""

    def __init__(self, lanes: "AgentLanes", component: Component):
        self.lanes = lanes
        self.component = component
        self.ctx = component.ctx

    def handle(self, stream: str, msg: Message) -> None:
        self.lanes.commit()
        self.component.handle(stream, msg)

    def reset(self, agent: str) -> None:
        self.component.reset(agent)


class AgentLanes:
    """Worker threads for the per-firefighter work of lane components (module docstring).

    ``install`` swaps the bus subscriptions of the lane components (and of the
    components reading their outputs) for stand-ins; ``publish`` is the runner's
    publishing function (component id, port, message), called at commits.
    """

    def __init__(self, bus: Bus, publish: Callable[[str, str, Message], None], workers: int):
        if workers < 1:
            raise ValueError(f"workers must be >= 1, got {workers}")
        self.bus = bus
        self.publish = publish
        self._workers = [_Worker(self, i) for i in range(workers)]
        self._assigned: dict[tuple[str, str], _Worker] = {}
        self._tasks: list[_Task] = []
        self._outstanding = 0
        self._idle = threading.Condition(threading.Lock())
        self.dispatched = 0
        self.started = False
        self._fatal: BaseException | None = None   # a fault under the ``raise`` policy

    def install(self, subs: dict[str, Subscription], lanes: Iterable[str],
                inputs: dict[str, tuple[str, ...]]) -> list[str]:
        """Put ``lanes`` (component ids) on the workers; ``inputs``: each component's
        input streams. Returns the lane components installed."""
        lanes = [cid for cid in lanes if cid in subs]
        if not lanes:
            return []
        for cid in lanes:
            subs[cid].component = _LaneProxy(self, subs[cid])  # type: ignore[assignment]
        prefixes = tuple(f"{cid}." for cid in lanes)
        for cid, sub in subs.items():
            if cid not in lanes and any(s.startswith(prefixes) or s == "*"
                                        for s in inputs.get(cid, ())):
                sub.component = _AfterCommit(self, sub.component)  # type: ignore[assignment]
        for cid in lanes:   # what lane components publish is held while on a worker
            ctx = subs[cid].component.ctx
            ctx._publish = self._capturing(ctx._publish)
        for w in self._workers:
            w.start()
        self.started = True
        return lanes

    def _capturing(self, publish: Callable[[str, str, Message], None]
                   ) -> Callable[[str, str, Message], None]:
        def captured(cid: str, port: str, msg: Message) -> None:
            task = getattr(_local, "task", None)
            if task is None:
                publish(cid, port, msg)
            else:
                task.outputs.append((cid, port, msg))
        return captured

    def submit(self, proxy: _LaneProxy, stream: str, msg: Message) -> None:
        key = (proxy.ctx.id, msg.agent)
        worker = self._assigned.get(key)
        if worker is None:
            worker = self._assigned[key] = self._workers[len(self._assigned) % len(self._workers)]
        task = _Task(proxy.component, proxy, stream, msg)
        with self._idle:
            self._outstanding += 1
        self._tasks.append(task)
        worker.submit(task)

    def _done(self) -> None:
        with self._idle:
            self._outstanding -= 1
            if not self._outstanding:
                self._idle.notify_all()

    def commit(self) -> None:
        """Wait for the workers, then publish what they held, in input order."""
        if not self._tasks or self._fatal is not None:
            return
        with self._idle:
            while self._outstanding:
                self._idle.wait()
        tasks, self._tasks = self._tasks, []
        failed: set[tuple[str, str]] = set()
        for task in tasks:
            key = (task.proxy.ctx.id, task.msg.agent)
            if key in failed:   # serially it would not have run after the fault
                self.bus.stats.count(key[0], "skipped_after_fault")
                continue
            for cid, port, msg in task.outputs:
                self.publish(cid, port, msg)
            if task.error is not None:
                failed.add(key)
                if task.proxy.sub.policy == "raise":   # raised by the runner, not inside
                    self._fatal = task.error           # another component's delivery
                    return
                self.bus.report_fault(task.proxy.sub, task.stream, task.msg, task.error)  # type: ignore[arg-type]

    def sync(self) -> None:
        """:meth:`commit`, from the runner's own loop: a fault of a component with the
        ``raise`` policy is raised here."""
        self.commit()
        if self._fatal is not None:
            fatal, self._fatal = self._fatal, None
            self.close()
            raise fatal

    def dispatched_one(self) -> None:
        """Count a dispatched message; :meth:`sync` every :data:`COMMIT_EVERY` (replays)."""
        self.dispatched += 1
        if self.dispatched % COMMIT_EVERY == 0 or self._fatal is not None:
            self.sync()

    def close(self) -> None:
        """Commit what is pending and stop the workers."""
        self.commit()
        if self.started:
            for w in self._workers:
                w.submit(None)
            for w in self._workers:
                w.join()
            self.started = False


class Backpressure:
    """Moves firefighters to a cheaper mode while a live kit falls behind (module docstring).

    ``components`` are the components offering ``degrade(agent, level)``; ``report``
    publishes a diagnostic. :meth:`observe` is called with each released message's
    wait [s] (wall time since it arrived, less the reorder window) and the wall time.
    """

    def __init__(self, components: dict[str, Any], report: Callable[[Diagnostic], None], *,
                 behind_s: float = 0.25, caught_up_s: float = 0.05, hold_s: float = 2.0):
        self.components = {cid: c for cid, c in components.items()
                           if callable(getattr(c, "degrade", None))}
        self.report = report
        self.behind_s, self.caught_up_s, self.hold_s = behind_s, caught_up_s, hold_s
        self.agents: list[str] = []       # firefighters seen, in order of first message
        self._seen: set[str] = set()
        self.degraded: list[str] = []     # in the order they were degraded
        self._last_change = -float("inf")
        self._calm_since: float | None = None
        self.steps = 0

    def saw(self, agent: str) -> None:
        """A message of ``agent`` was published (the firefighters that can be degraded)."""
        if agent and agent not in self._seen:
            self._seen.add(agent)
            self.agents.append(agent)

    def observe(self, wait: float, now: float, t: float) -> None:
        """A live message queued ``wait`` [s] before the pipeline took it; ``now`` is the
        wall time [s], ``t`` its data time (for the diagnostic)."""
        if not self.components:
            return
        if wait > self.behind_s:
            self._calm_since = None
            if now - self._last_change >= self.hold_s / 4:
                todo = [a for a in self.agents if a not in self.degraded]
                if todo:
                    self._set(todo[-1], 1, t, now, f"the kit is {wait:.2f} s behind")
            return
        if wait < self.caught_up_s:
            if self._calm_since is None:
                self._calm_since = now
            if self.degraded and now - self._calm_since >= self.hold_s \
                    and now - self._last_change >= self.hold_s:
                self._set(self.degraded[-1], 0, t, now, "the kit has caught up")

    def _set(self, agent: str, level: int, t: float, now: float, why: str) -> None:
        changes = []
        for cid, comp in self.components.items():
            what = comp.degrade(agent, level)
            if what:
                changes.append(f"{cid}: {what}")
        if level:
            self.degraded.append(agent)
        else:
            self.degraded.remove(agent)
        self._last_change = now
        self.steps += 1
        code = "degraded" if level else "restored"
        text = (f"{agent}: {why}; {'cheaper mode' if level else 'normal mode'}"
                f"{': ' + '; '.join(changes) if changes else ''} (nothing is dropped: "
                "every frame is recorded and processed)")
        self.report(Diagnostic(t=t, agent=agent, component="runner", level="warning"
                               if level else "info", code=code, text=text, active=bool(level)))
