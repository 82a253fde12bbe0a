"""The source role: where messages come from (a recorded file, the simulator, a live link).

Contract of a :class:`Source`:

* :meth:`Source.messages` yields ``(port, message)`` pairs; each port's messages in
  (mostly) increasing measurement time. The timeline merges ports and sources and puts
  late arrivals within its reorder window back in order.
* A *live* source (``live = True``) blocks while it waits for data; it runs in its own
  thread, and :meth:`Source.stop` must make :meth:`messages` return soon. Every raw
  frame a live source receives is recorded before it is published.
* ``input_param`` names the parameter ``firenav run --input PATH`` sets.
* A source that brings its own building (the simulator) sets ``provides_building`` and
  returns it from :meth:`Source.building`; the validator then accepts building-needing
  plugins without a ``building:`` in the pipeline.
* A source never raises for bad input in its data: it counts it (``ctx.count``), reports
  it, and goes on with the next record. Damage in one device's data is confined to that
  device.
"""
from __future__ import annotations

from abc import abstractmethod
from collections.abc import Iterator
from typing import Any, ClassVar

from ..messages import Message
from .component import Component

__all__ = ["Source"]


class Source(Component):
    """Produces messages: a recorded file, the simulator or a live transport."""

    kind = "source"
    #: Live sources are paced by the outside world and run in a thread.
    live: ClassVar[bool] = False
    #: Name of the parameter that ``firenav run --input PATH`` sets, if any.
    input_param: ClassVar[str | None] = None
    #: True when :meth:`building` returns the building of the data (the simulator's).
    provides_building: ClassVar[bool] = False

    @abstractmethod
    def messages(self) -> Iterator[tuple[str, Message]]:
        """Every ``(port, message)`` of this source, in (mostly) increasing time."""

    def duration(self) -> tuple[float, float] | None:
        """(first, last) measurement time if known in advance, for progress display."""
        return None

    def building(self) -> Any:
        """The building model this source brings (when ``provides_building``), else None."""
        return None

    def stop(self) -> None:
        """Ask a live source to stop; :meth:`messages` should then return soon."""
