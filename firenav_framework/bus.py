"""Synchronous event bus that isolates plugin faults.

Messages published on a stream are delivered, depth first and in subscription order,
to every subscriber of that stream; a message a subscriber publishes while handling
is delivered before the next subscriber sees the original one. That keeps runs
deterministic.

When a component raises while handling a message, the fault is counted, reported as
an ``error`` :class:`Diagnostic` with code ``plugin_fault`` naming the component and
the agent, and the component's fault policy decides what happens next:

``disable_agent`` (default)
    The component gets no more messages of that agent; its other agents, and every
    other component, carry on.
``restart``
    The component forgets the agent (``reset(agent)``) and carries on; after
    ``max_restarts`` faults for the same agent it is disabled for that agent.
``disable``
    The component gets no more messages at all.
``raise``
    The exception stops the run (for debugging).

What counts as a fault of the component: any exception, ``SystemExit`` (a plugin calling
``sys.exit()``), a ``KeyboardInterrupt`` the plugin raises itself (the user's own Ctrl-C
is handled by the runner, see :mod:`firenav_framework.watchdog`), and the watchdog's
:class:`~firenav_framework.watchdog.PluginTimeout` (a call past its time limit) and
:class:`~firenav_framework.watchdog.PluginInterrupted` (a call cut short because the
run is stopping; the component is then disabled).
Every call into a component goes through the watchdog when the bus has one.
"""
from __future__ import annotations

import logging
import traceback
from collections import defaultdict
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Literal

from .contract import Component
from .messages import Diagnostic, Message
from .stats import RunStats
from .watchdog import LIFECYCLE_FACTOR, PluginInterrupted, PluginTimeout, Watchdog

log = logging.getLogger("firenav.bus")

FaultPolicy = Literal["disable_agent", "restart", "disable", "raise"]
FAULT_POLICIES: tuple[str, ...] = ("disable_agent", "restart", "disable", "raise")


@dataclass
class Subscription:
    component: Component
    policy: FaultPolicy = "disable_agent"
    agents: frozenset[str] | None = None  # None: every agent
    max_restarts: int = 3
    watchdog: float | None = None  # time limit of one call [s]; None: not timed
    #: every agent (and radio node) whose data the component has received, for the
    #: runner's relabelling check
    received: set[str] = field(default_factory=set)


@dataclass
class Fault:
    """One exception raised by a component."""

    component: str
    agent: str
    stream: str
    t: float
    error: str
    where: str
    action: str


@dataclass
class Bus:
    stats: RunStats = field(default_factory=RunStats)
    _subs: dict[str, list[Subscription]] = field(default_factory=lambda: defaultdict(list))
    _disabled: set[tuple[str, str | None]] = field(default_factory=set)
    _restarts: dict[tuple[str, str], int] = field(default_factory=lambda: defaultdict(int))
    faults: list[Fault] = field(default_factory=list)
    #: Called for every published message (recorders and monitors), before subscribers.
    taps: list[Callable[[str, Message], None]] = field(default_factory=list)
    #: Times every call into a component (the runner sets it for the run).
    watchdog: Watchdog | None = None

    def subscribe(self, stream: str, sub: Subscription) -> None:
        self._subs[stream].append(sub)

    def subscribers(self, stream: str) -> list[Subscription]:
        return list(self._subs.get(stream, ()))

    def publish(self, stream: str, msg: Message) -> None:
        """Deliver ``msg`` to everyone subscribed to ``stream``."""
        self.stats.seen(stream)
        for tap in self.taps:
            tap(stream, msg)
        for sub in self._subs.get(stream, ()):
            self.deliver(sub, stream, msg)

    def deliver(self, sub: Subscription, stream: str, msg: Message) -> None:
        cid = sub.component.ctx.id
        agent = msg.agent
        if sub.agents is not None and agent and agent not in sub.agents:
            return
        if (cid, None) in self._disabled or (cid, agent) in self._disabled:
            self.stats.count(cid, "skipped_after_fault")
            return
        if agent:
            sub.received.add(agent)
        for name in msg.node_fields:
            sub.received.add(getattr(msg, name))
        self._guarded(sub, stream, msg, sub.watchdog, "handle", sub.component.handle,
                      stream, msg)

    def call(self, sub: Subscription, what: str, fn: Callable[[], None], t: float = 0.0) -> None:
        """Run a lifecycle call (start/finish) under the same fault policy (and the
        watchdog, with :data:`~firenav_framework.watchdog.LIFECYCLE_FACTOR` limits)."""
        self._guarded(sub, what, Diagnostic(t=t, component="", level="", code="", text=""),
                      sub.watchdog and sub.watchdog * LIFECYCLE_FACTOR, what, fn)

    def _guarded(self, sub: Subscription, stream: str, msg: Message, limit: float | None,
                 what: str, fn: Callable[..., None], *args: Any) -> None:
        """``fn(*args)`` under the watchdog (``limit`` [s]) and ``sub``'s fault policy; a
        contained fault is reported against ``stream`` and ``msg``."""
        wd = self.watchdog
        try:
            if wd is not None:
                wd.enter(sub.component.ctx.id, limit, what)
            try:
                fn(*args)
            finally:
                if wd is not None:
                    wd.leave()
        except BaseException as exc:
            if sub.policy == "raise" or not self.contained(exc):
                raise
            self.report_fault(sub, stream, msg, exc)

    def contained(self, exc: BaseException) -> bool:
        """Whether ``exc``, raised in a component, is that component's fault: an
        exception, ``SystemExit``, the watchdog's interruptions, and a KeyboardInterrupt
        unless the user's (only a runner with a watchdog tells them apart)."""
        if isinstance(exc, KeyboardInterrupt):
            return self.watchdog is not None and not self.watchdog.user_interrupt
        return isinstance(exc, (Exception, SystemExit, PluginTimeout, PluginInterrupted))

    def report_fault(self, sub: Subscription, stream: str, msg: Message,
                     exc: BaseException) -> None:
        cid, agent = sub.component.ctx.id, msg.agent
        frame = traceback.extract_tb(exc.__traceback__)[-1] if exc.__traceback__ else None
        where = f"{frame.filename}:{frame.lineno}" if frame else "?"
        if sub.policy == "restart" and self._restarts[(cid, agent)] < sub.max_restarts:
            self._restarts[(cid, agent)] += 1
            action = f"restarted for agent '{agent}' ({self._restarts[(cid, agent)]}/{sub.max_restarts})"
            try:
                sub.component.reset(agent)
            except BaseException as reset_exc:  # a reset that fails ends the restarts
                if not self.contained(reset_exc):
                    raise
                action = f"reset failed ({reset_exc}); disabled for agent '{agent}'"
                self._disabled.add((cid, agent))
        elif sub.policy == "disable" or isinstance(exc, PluginInterrupted):
            action = "disabled"  # (cut short to stop the run: it gets nothing more)
            self._disabled.add((cid, None))
        else:
            action = f"disabled for agent '{agent}'" if agent else "disabled for unassigned data"
            self._disabled.add((cid, agent))
        text = str(exc) or (self.watchdog.last_overrun() if self.watchdog is not None and
                            isinstance(exc, (PluginTimeout, PluginInterrupted)) else "")
        fault = Fault(cid, agent, stream, msg.t, f"{type(exc).__name__}: {text}", where, action)
        self.faults.append(fault)
        self.stats.count(cid, "faults")
        log.error("plugin '%s' raised %s while handling %s (agent '%s', t=%.3f) at %s; %s",
                  cid, fault.error, stream, agent, msg.t, where, action)
        log.debug("traceback:\n%s", "".join(traceback.format_exception(exc)))
        report = Diagnostic(t=msg.t, agent=agent, component=cid, level="error",
                            code="plugin_fault", text=f"{fault.error} at {where}; {action}")
        stream_out = f"{cid}.diagnostics"
        self.stats.seen(stream_out)
        for tap in self.taps:
            tap(stream_out, report)
        for other in self._subs.get(stream_out, ()):
            if other.component is not sub.component:
                self.deliver(other, stream_out, report)
