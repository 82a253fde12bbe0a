"""The part of the contract every plugin kind shares: :class:`Component`.

A plugin is a class with

* ``name``: the name used in pipeline YAML (``plugin: particle_filter``), letters,
  digits, ``_`` and ``-``; unique within its kind;
* a docstring whose first line is the summary ``firenav plugins list`` shows;
* ``Params``: a pydantic model (:class:`~.params.Params`) declaring its parameters,
  at once the YAML schema, the ``firenav plugins show`` table and the docs;
* ``inputs``: the message types it accepts on its input streams;
* ``outputs``: its output ports and their message types (``{"pose": PoseEstimate}``);
  every component also has a ``diagnostics`` port. A plugin whose ports depend on its
  parameters overrides :meth:`Component.output_ports`.

Lifecycle, driven by the runner: the class is constructed once with validated
parameters and a :class:`~.context.Context`; :meth:`~Component.start` is called before
the first message, then the role's hook (``handle`` for sensors, estimators, sinks and
constraints with inputs; ``messages`` for sources) for every message in time order,
then :meth:`~Component.finish` once after the last.

Time: every message carries its measurement time ``t`` [s] on the pipeline clock; the
timeline delivers messages in non-decreasing ``t`` (ticks included). A component never
reads the wall clock to order data.

Faults: a component never lets one bad message raise (count it, report it, skip it).
If it does raise, the bus contains the fault by the component's ``on_error`` policy
(``disable_agent``: no more data of that firefighter; ``restart``: :meth:`reset` the
firefighter and carry on; ``disable``; ``raise``). Everything a component owns for one
firefighter therefore lives in per-agent state (:class:`~.context.PerAgent`), so
:meth:`reset` can forget exactly one firefighter. What a firefighter left in the
building (an RFID tag stuck on a door) is not that firefighter's state: it stays
through :meth:`reset`, so that the others' reads of it keep counting, and the ports
that publish such facts are named in :attr:`Component.world_outputs`.

Messages are immutable and shared by every receiver: a component never changes a
received message or its arrays; it publishes new ones.
"""
from __future__ import annotations

from abc import ABC
from typing import ClassVar

from ..messages import Diagnostic, Message
from .context import Context
from .params import Params

__all__ = ["Component"]


class Component(ABC):
    """Base of every plugin kind (see the module docstring for the shared contract)."""

    #: "source" | "sensor" | "estimator" | "constraint" | "sink" (set by the role base).
    kind: ClassVar[str] = ""
    #: The name pipelines use.
    name: ClassVar[str] = ""
    Params: ClassVar[type[Params]] = Params
    inputs: ClassVar[tuple[type[Message], ...]] = ()
    outputs: ClassVar[dict[str, type[Message]]] = {}
    #: Output ports that publish facts about the building, not about the firefighter
    #: whose message caused them (a tag deployment): :meth:`reset` keeps them, so the
    #: same fact again after a reset is a duplicate, not a new publication.
    world_outputs: ClassVar[tuple[str, ...]] = ()
    #: True when the plugin reads ``ctx.building``: the validator then requires a
    #: building (the pipeline's ``building:`` or a source that brings one).
    needs_building: ClassVar[bool] = False

    def __init__(self, params: Params, ctx: Context):
        self.params = params
        self.ctx = ctx

    @classmethod
    def output_ports(cls, params: Params) -> dict[str, type[Message]]:
        """Output ports for these parameters (every component may also emit diagnostics)."""
        return {**cls.outputs, "diagnostics": Diagnostic}

    @classmethod
    def tick_period(cls, params: Params) -> float | None:
        """Period [s] of :class:`~firenav_framework.messages.Tick` messages this component
        wants on top of its inputs (e.g. an EKF updating once per second), or None."""
        return None

    @classmethod
    def summary(cls) -> str:
        """First line of the class docstring."""
        doc = (cls.__doc__ or "").strip()
        return doc.splitlines()[0].strip() if doc else ""

    def start(self) -> None:
        """Called once before the first message."""

    def finish(self) -> None:
        """Called once after the last message: flush buffered output here."""

    def reset(self, agent: str) -> None:
        """Forget everything about ``agent`` (the ``restart`` fault policy calls this),
        except the building facts of :attr:`world_outputs`."""
