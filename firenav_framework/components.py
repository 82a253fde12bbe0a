"""Base classes for the five plugin kinds and the context they run in.

A plugin is a class with

* ``name``: the name used in pipeline YAML (``plugin: particle_filter``);
* ``Params``: a pydantic model declaring its parameters (``extra="forbid"``), which
  is at once the YAML schema, the ``firenav plugins show`` table and the docs;
* ``inputs``: the message types it accepts on its input streams;
* ``outputs``: its output ports and their message types (``{"pose": PoseEstimate}``);
  a plugin whose ports depend on its parameters overrides :meth:`output_ports`.

Components receive messages through :meth:`Component.handle` and publish through
their :class:`Context`. Everything a component owns for one firefighter should live
in per-agent state (see :class:`PerAgent`), so that a fault while handling one
agent's data can be contained to that agent.
"""
from __future__ import annotations

import logging
from collections.abc import Callable, Iterator
from contextvars import ContextVar
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar, Generic, TypeVar

from pydantic import BaseModel, ConfigDict, Field

from .messages import Diagnostic, Message

if TYPE_CHECKING:
    from .stats import RunStats

__all__ = [
    "Params", "param", "Component", "Source", "Sensor", "Estimator", "Constraint",
    "Sink", "Context", "PerAgent", "KINDS", "pipeline_dir",
]

KINDS = ("source", "sensor", "estimator", "constraint", "sink")

#: Folder of the pipeline file being validated or run (see :func:`pipeline_dir`).
PIPELINE_DIR: ContextVar[Path | None] = ContextVar("firenav_pipeline_dir", default=None)


def pipeline_dir() -> Path:
    """Folder of the pipeline being validated or run, which relative parameter paths are
    relative to; for code outside a pipeline, the working directory. Class methods such as
    ``output_ports`` use it to find a file named in the parameters before construction."""
    return PIPELINE_DIR.get() or Path.cwd()


class Params(BaseModel):
    """Base for plugin parameter models: unknown keys are errors, values are checked."""

    model_config = ConfigDict(extra="forbid", frozen=True, validate_default=True)


def param(default: Any = ..., *, unit: str | None = None, description: str = "",
          **constraints: Any) -> Any:
    """A pydantic ``Field`` that also records the physical unit of a parameter.

    >>> class P(Params):
    ...     range_m: float = param(5.0, unit="m", description="read range", gt=0)
    """
    extra = {"unit": unit} if unit else None
    return Field(default, description=description, json_schema_extra=extra, **constraints)


S = TypeVar("S")


class PerAgent(Generic[S]):
    """Lazily created state per firefighter, with reset for the restart policy."""

    def __init__(self, factory: Callable[[str], S]):
        self._factory = factory
        self._states: dict[str, S] = {}

    def __getitem__(self, agent: str) -> S:
        state = self._states.get(agent)
        if state is None:
            state = self._states[agent] = self._factory(agent)
        return state

    def __setitem__(self, agent: str, state: S) -> None:
        self._states[agent] = state

    def __contains__(self, agent: str) -> bool:
        return agent in self._states

    def __iter__(self) -> Iterator[str]:
        return iter(sorted(self._states))

    def items(self) -> list[tuple[str, S]]:
        return [(a, self._states[a]) for a in sorted(self._states)]

    def reset(self, agent: str | None = None) -> None:
        if agent is None:
            self._states.clear()
        else:
            self._states.pop(agent, None)


class Context:
    """What the runner gives a component: identity, publishing, counters, shared data."""

    def __init__(self, component_id: str, *, stats: "RunStats",
                 publish: Callable[[str, str, Message], None],
                 base_dir: Path, output_dir: Path | None = None,
                 building_loader: Callable[[], Any] | None = None):
        self.id = component_id
        self.stats = stats
        self._publish = publish
        self.base_dir = base_dir
        self.output_dir = output_dir
        self._building_loader = building_loader
        self.log = logging.getLogger(f"firenav.{component_id}")

    def publish(self, port: str, msg: Message) -> None:
        """Publish ``msg`` on this component's output ``port``."""
        self._publish(self.id, port, msg)

    def count(self, what: str, n: int = 1) -> None:
        """Count an event (a skipped sample, a bad frame ...) for the run summary."""
        if n:
            self.stats.count(self.id, what, n)

    def diagnose(self, t: float, level: str, code: str, text: str, *, agent: str = "",
                 active: bool = True) -> None:
        """Publish a :class:`Diagnostic` on this component's ``diagnostics`` port."""
        self.publish("diagnostics", Diagnostic(t=t, agent=agent, component=self.id,
                                               level=level, code=code, text=text,
                                               active=active))

    def resolve(self, path: str | Path) -> Path:
        """A path from the pipeline, relative to the pipeline file's folder."""
        p = Path(path).expanduser()
        return p if p.is_absolute() else (self.base_dir / p)

    @property
    def building(self) -> Any:
        """The pipeline's building model (loaded once, shared by all components)."""
        if self._building_loader is None:
            raise RuntimeError(f"{self.id}: this pipeline has no building")
        return self._building_loader()


class Component:
    """Base of every plugin kind. Subclasses set the class attributes below."""

    kind: ClassVar[str] = ""
    name: ClassVar[str] = ""
    Params: ClassVar[type[Params]] = Params
    inputs: ClassVar[tuple[type[Message], ...]] = ()
    outputs: ClassVar[dict[str, type[Message]]] = {}
    #: True when the plugin reads the pipeline's building model.
    needs_building: ClassVar[bool] = False

    def __init__(self, params: Params, ctx: Context):
        self.params = params
        self.ctx = ctx

    @classmethod
    def output_ports(cls, params: Params) -> dict[str, type[Message]]:
        """Output ports for these parameters (every component may also emit diagnostics)."""
        return {**cls.outputs, "diagnostics": Diagnostic}

    @classmethod
    def summary(cls) -> str:
        """First line of the class docstring."""
        doc = (cls.__doc__ or "").strip()
        return doc.splitlines()[0].strip() if doc else ""

    def start(self) -> None:
        """Called once before the first message."""

    def handle(self, stream: str, msg: Message) -> None:
        """Process one message from input ``stream``."""

    def finish(self) -> None:
        """Called once after the last message: flush buffered output here."""

    def reset(self, agent: str) -> None:
        """Forget everything about ``agent`` (the ``restart`` fault policy calls this)."""


class Source(Component):
    """Produces messages: a recorded file, the simulator or a live transport.

    :meth:`messages` yields ``(port, message)`` pairs, each port's messages in
    (mostly) increasing time; the timeline merges ports and sources. A *live*
    source blocks while waiting for data and is run in its own thread.
    """

    kind = "source"
    #: Live sources are paced by the outside world and run in a thread.
    live: ClassVar[bool] = False
    #: Name of the parameter that ``firenav run --input PATH`` sets, if any.
    input_param: ClassVar[str | None] = None

    def messages(self) -> Iterator[tuple[str, Message]]:
        raise NotImplementedError

    def duration(self) -> tuple[float, float] | None:
        """(first, last) measurement time if known in advance, for progress display."""
        return None

    def building(self) -> Any:
        """A building model this source brings (the simulator does), else None."""
        return None

    def stop(self) -> None:
        """Ask a live source to stop; :meth:`messages` should then return soon."""


class Sensor(Component):
    """Decodes and conditions the data of one kind of device."""

    kind = "sensor"


class Estimator(Component):
    """Turns measurements (or another estimator's output) into state estimates.

    ``provides`` names the capabilities its constraints can use (e.g.
    ``{"particles"}``); the validator refuses a constraint whose ``requires`` is not
    covered. Attached constraints are in ``self.constraints`` after construction.
    """

    kind = "estimator"
    provides: ClassVar[frozenset[str]] = frozenset()

    def __init__(self, params: Params, ctx: Context):
        super().__init__(params, ctx)
        self.constraints: list[Constraint] = []


class Constraint(Component):
    """Knowledge an estimator can apply (walls, doors, search patterns, ...).

    A constraint speaks its estimator's language, so it declares the capability it
    ``requires``. It may also read streams of its own (``inputs``), e.g. UWB ranges.
    """

    kind = "constraint"
    requires: ClassVar[frozenset[str]] = frozenset()


class Sink(Component):
    """Consumes streams: track files, a recorder, MAVLink out, the live view."""

    kind = "sink"


KIND_BASES: dict[str, type[Component]] = {
    "source": Source, "sensor": Sensor, "estimator": Estimator,
    "constraint": Constraint, "sink": Sink,
}
