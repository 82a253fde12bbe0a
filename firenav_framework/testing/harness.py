"""Running one plugin without a pipeline, the way the runner would run it.

:class:`Session` holds one instance of a plugin class with a context that records what
it publishes and counts; it delivers messages through the role's hook with the
:class:`~firenav_framework.messages.Tick` messages of the plugin's
:meth:`~firenav_framework.contract.Component.tick_period` interleaved (at multiples
of the period, before any later message, as the timeline does), and hosts a
constraint under an estimator that accepts its capability. :func:`make_component` and
:func:`run_component` are the one-line forms for tests.
"""
from __future__ import annotations

import math
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

from pydantic import BaseModel

from ..contract import Component, Constraint, Context, Estimator, Params, Source
from ..messages import Message, Tick
from ..stats import RunStats

__all__ = ["Recorder", "Session", "make_component", "run_component", "with_ticks"]

#: Component id of the plugin under test, and of the estimator hosting a constraint.
UNDER_TEST = "under_test"
HOST = "host"


class Recorder:
    """Collects what components publish, in order.

    ``records`` holds ``(component id, port, message)`` of every component of the
    session; ``published`` the ``(port, message)`` pairs of the plugin under test.
    """

    def __init__(self, cid: str = UNDER_TEST) -> None:
        self.cid = cid
        self.records: list[tuple[str, str, Message]] = []

    def __call__(self, cid: str, port: str, msg: Message) -> None:
        self.records.append((cid, port, msg))

    @property
    def published(self) -> list[tuple[str, Message]]:
        return [(p, m) for c, p, m in self.records if c == self.cid]

    def on(self, port: str) -> list[Message]:
        """What the plugin under test published on ``port``."""
        return [m for c, p, m in self.records if c == self.cid and p == port]


def validated(cls: type[Component], params: dict | BaseModel | None) -> Params:
    """``params`` checked against ``cls.Params`` (a model instance is used as it is)."""
    if isinstance(params, BaseModel):
        return params
    return cls.Params.model_validate(params or {})


def with_ticks(messages: Iterable[tuple[str, Message]], period: float | None,
               state: list[int] | None = None) -> Iterator[tuple[str, Message]]:
    """``messages`` with a :class:`Tick` on stream ``ticks.<period>`` at every multiple of
    ``period`` [s] from the first message's time on, each before any later message.

    ``state`` (a one-element list holding the next tick index) carries the tick clock
    across calls, as one pipeline run does.
    """
    state = state if state is not None else []
    stream = f"ticks.{period:g}" if period else ""
    for item in messages:
        if period:
            t = item[1].t
            if not state:
                state.append(math.ceil(t / period - 1e-9))
            while state[0] * period <= t:
                yield stream, Tick(t=state[0] * period, period=period)
                state[0] += 1
        yield item


class _Target:
    """A component of a session and the message types routed to it (None: all)."""

    def __init__(self, component: Component, inputs: tuple[type[Message], ...] | None):
        self.component = component
        self.inputs = inputs
        self.period = type(component).tick_period(component.params)
        self.tick_state: list[int] = []


class Session:
    """One instance of a plugin (and of the estimator hosting it, for a constraint).

    ``host`` is the estimator class a constraint is attached to (ignored for other
    kinds); messages whose type the constraint's ``inputs`` list go to the constraint,
    those the host's ``inputs`` list to the host, as their streams would in a pipeline.
    With ``ticks`` False no ticks are added (a test that hands over its own).
    """

    def __init__(self, cls: type[Component], params: dict | BaseModel | None = None, *,
                 building: Any = None, base_dir: Path | None = None,
                 output_dir: Path | None = None, cid: str = UNDER_TEST,
                 host: type[Estimator] | None = None,
                 host_params: dict | BaseModel | None = None, ticks: bool = True):
        self.cls = cls
        self.params = validated(cls, params)
        self.stats = RunStats()
        self.recorder = Recorder(cid)
        self.building = building
        self._base_dir = base_dir or Path.cwd()
        self._output_dir = output_dir
        self.ticks = ticks
        self.component = cls(self.params, self.context(cid))
        self.host: Estimator | None = None
        self._targets: list[_Target] = []
        if isinstance(self.component, Constraint) and host is not None:
            self.host = host(validated(host, host_params), self.context(HOST))
            self.host.constraints.append(self.component)
            self._targets.append(_Target(self.host, host.inputs))
            self._targets.append(_Target(self.component, cls.inputs))
        else:
            self._targets.append(_Target(self.component, None))

    def context(self, cid: str) -> Context:
        """A context for component ``cid`` that records into this session."""
        loader = (lambda: self.building) if self.building is not None else None
        return Context(cid, stats=self.stats, publish=self.recorder,
                       base_dir=self._base_dir, output_dir=self._output_dir,
                       building_loader=loader)

    @property
    def components(self) -> list[Component]:
        return [t.component for t in self._targets]

    def start(self) -> "Session":
        for comp in self.components:
            comp.start()
        return self

    def feed(self, messages: Iterable[tuple[str, Message]]) -> None:
        """Deliver ``(stream, message)`` pairs in the given order, ticks interleaved."""
        for item in messages:
            for target in self._targets:
                if target.inputs is not None and not isinstance(item[1], target.inputs):
                    continue
                if self.ticks and not isinstance(item[1], Tick):
                    for stream, msg in with_ticks([item], target.period, target.tick_state):
                        target.component.handle(stream, msg)  # type: ignore[attr-defined]
                else:
                    target.component.handle(*item)  # type: ignore[attr-defined]

    def source_messages(self) -> None:
        """Run a source's :meth:`~firenav_framework.contract.Source.messages` to its end,
        recording every ``(port, message)`` as published."""
        assert isinstance(self.component, Source)
        for port, msg in self.component.messages():
            self.recorder(self.recorder.cid, port, msg)

    def reset(self, agent: str) -> None:
        for comp in self.components:
            comp.reset(agent)

    def finish(self) -> Recorder:
        """``finish`` every component and publish their pending reports (the runner's end)."""
        for comp in self.components:
            if not isinstance(comp, Source):
                comp.finish()
            comp.ctx.flush_reports()
        return self.recorder

    def run(self, messages: Iterable[tuple[str, Message]] = ()) -> Recorder:
        """start, the source's messages (for a source) or ``messages``, finish."""
        self.start()
        if isinstance(self.component, Source):
            self.source_messages()
        self.feed(messages)
        return self.finish()


def make_component(cls: type[Component], params: dict | BaseModel | None = None, *,
                   building: Any = None, base_dir: Path | None = None,
                   output_dir: Path | None = None, cid: str = UNDER_TEST
                   ) -> tuple[Component, Recorder, RunStats]:
    """Construct ``cls`` with validated ``params`` and a context that records output."""
    s = Session(cls, params, building=building, base_dir=base_dir, output_dir=output_dir,
                cid=cid)
    return s.component, s.recorder, s.stats


def run_component(cls: type[Component], params: dict | BaseModel | None = None,
                  messages: Iterable[tuple[str, Message]] = (), **kw: Any) -> Recorder:
    """Start a component, feed it ``(stream, message)`` pairs (ticks interleaved as a
    pipeline would), finish it; return what it published."""
    return Session(cls, params, **kw).run(messages)
