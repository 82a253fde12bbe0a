"""Helpers for testing plugins without a pipeline, and a conformance check for vendors.

>>> from firenav_framework.testing import check_plugin, run_component
>>> published = run_component(MySensor, {"gain": 2.0}, [("in", some_message)])
>>> check_plugin(MySensor, sample_input=[("in", some_message)])

``check_plugin`` is what a vendor puts in their own test suite: it checks that the
class is a well-formed firenav plugin (kind, name, parameter model, ports) and, given
sample input, that everything it publishes goes to a declared port with the declared
message type, and that ``reset``/``finish`` work.
"""
from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import Any

from pydantic import BaseModel

from .contract import Component, Context, Source
from .messages import Message
from .registry import plugin_class_problem
from .stats import RunStats


class Recorder:
    """Collects what a component publishes: ``(port, message)`` in order."""

    def __init__(self) -> None:
        self.published: list[tuple[str, Message]] = []

    def __call__(self, cid: str, port: str, msg: Message) -> None:
        self.published.append((port, msg))

    def on(self, port: str) -> list[Message]:
        return [m for p, m in self.published if p == port]


def make_component(cls: type[Component], params: dict | BaseModel | None = None, *,
                   building: Any = None, base_dir: Path | None = None,
                   output_dir: Path | None = None, cid: str = "under_test"
                   ) -> tuple[Component, Recorder, RunStats]:
    """Construct ``cls`` with validated ``params`` and a context that records output."""
    if not isinstance(params, BaseModel):
        params = cls.Params.model_validate(params or {})
    stats, rec = RunStats(), Recorder()
    ctx = Context(cid, stats=stats, publish=rec, base_dir=base_dir or Path.cwd(),
                  output_dir=output_dir,
                  building_loader=(lambda: building) if building is not None else None)
    return cls(params, ctx), rec, stats


def run_component(cls: type[Component], params: dict | BaseModel | None = None,
                  messages: Iterable[tuple[str, Message]] = (), **kw: Any) -> Recorder:
    """Start a component, feed it ``(stream, message)`` pairs, finish it; return its output."""
    comp, rec, _ = make_component(cls, params, **kw)
    comp.start()
    if isinstance(comp, Source):
        for port, msg in comp.messages():
            rec(comp.ctx.id, port, msg)
    for stream, msg in messages:
        comp.handle(stream, msg)
    comp.finish()
    return rec


def check_plugin(cls: type[Component], params: dict | None = None, *,
                 sample_input: Iterable[tuple[str, Message]] = (), **kw: Any) -> Recorder:
    """Assert that ``cls`` is a conforming firenav plugin; returns what it published."""
    problem = plugin_class_problem(cls)
    assert problem is None, problem
    assert cls.summary(), f"{cls.__name__} needs a docstring: its first line is the summary"
    for name, field in cls.Params.model_fields.items():
        assert field.description, f"{cls.__name__}.Params.{name} needs a description"
    validated = cls.Params.model_validate(params or {})
    ports = cls.output_ports(validated)
    for port, mtype in ports.items():
        assert isinstance(mtype, type) and issubclass(mtype, Message), \
            f"{cls.__name__}: output port '{port}' must map to a Message type, got {mtype!r}"
    for mtype in cls.inputs:
        assert isinstance(mtype, type) and issubclass(mtype, Message), \
            f"{cls.__name__}: inputs must be Message types, got {mtype!r}"
    sample_input = list(sample_input)
    for stream, msg in sample_input:
        assert isinstance(msg, cls.inputs), \
            f"sample input {type(msg).__name__} is not among {cls.__name__}.inputs"
    rec = run_component(cls, validated, sample_input, **kw)
    for port, msg in rec.published:
        assert port in ports, f"{cls.__name__} published on undeclared port '{port}'"
        assert isinstance(msg, ports[port]), (
            f"{cls.__name__} published {type(msg).__name__} on '{port}', "
            f"declared {ports[port].__name__}")
    comp, _, _ = make_component(cls, validated, **kw)
    for _, msg in sample_input[:1]:
        comp.reset(msg.agent)
    return rec
