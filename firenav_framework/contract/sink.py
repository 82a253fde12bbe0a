"""The sink role: consumers of streams (track files, recorders, MAVLink out, the live view).

Contract of a :class:`Sink`:

* Input: any streams, wildcards allowed in the pipeline (``"*.diagnostics"``; a wildcard
  never matches another sink's own streams).
* Files go under the run's output folder (``--output``) only: :meth:`FileSink.out_path`
  refuses names that leave it.
* A sink must not hold up the pipeline: slow work (a plot, a network client) is done
  off the pipeline thread or at :meth:`~.component.Component.finish`.
"""
from __future__ import annotations

from abc import abstractmethod
from pathlib import Path

from ..messages import Message
from .component import Component

__all__ = ["Sink", "FileSink", "OutputPathError"]


class OutputPathError(ValueError):
    """A sink's file name would leave the run's output folder."""


class Sink(Component):
    """Consumes streams: track files, a recorder, MAVLink out, the live view."""

    kind = "sink"

    @abstractmethod
    def handle(self, stream: str, msg: Message) -> None:
        """Process one message from input ``stream`` (in time order)."""


class FileSink(Sink):
    """A sink that writes files under the run's output folder (``--output``)."""

    def out_path(self, name: str) -> Path:
        """``name`` inside the output folder (created on demand).

        Raises :class:`OutputPathError` for an absolute name or one that leaves the
        folder (``..``).
        """
        root = (self.ctx.output_dir or Path("out")).resolve()
        p = Path(name).expanduser()
        target = (root / p).resolve()
        if p.is_absolute() or not target.is_relative_to(root):
            raise OutputPathError(f"{self.ctx.id}: file {name!r} is outside the output "
                                  f"folder {root}")
        target.parent.mkdir(parents=True, exist_ok=True)
        return target

    @staticmethod
    def stream_slug(stream: str) -> str:
        return stream.replace(".", "_")
