"""The sink role: consumers of streams (track files, recorders, MAVLink out, the live view).

Contract of a :class:`Sink`:

* Input: any streams, wildcards allowed in the pipeline (``"*.diagnostics"``; a wildcard
  never matches another sink's own streams).
* Files go under the run's output folder (``--output``) only: a file-name parameter is
  an :data:`OutputName` (validation refuses an absolute name or ``..``, located), and
  :meth:`FileSink.out_path` refuses names that leave the folder at run time (symlinks
  included).
* A sink must not hold up the pipeline: slow work (a plot, a network client) is done
  off the pipeline thread or at :meth:`~.component.Component.finish`.
"""
from __future__ import annotations

from abc import abstractmethod
from pathlib import Path, PurePosixPath
from typing import Annotated

from pydantic import AfterValidator

from ..messages import Message
from .component import Component

__all__ = ["Sink", "FileSink", "OutputPathError", "OutputName", "output_name_problem"]


class OutputPathError(ValueError):
    """A sink's file name would leave the run's output folder."""


def output_name_problem(name: str) -> str | None:
    """Why ``name`` is not a file name inside the output folder (None when it is):
    empty, absolute, starting with ``~`` or with a ``..`` part."""
    parts = PurePosixPath(name.replace("\\", "/"))
    if not name.strip():
        return "is empty"
    if parts.is_absolute() or name.startswith("~") or (len(name) > 1 and name[1] == ":"):
        return "is an absolute path"
    if ".." in parts.parts:
        return "contains '..'"
    return None


def _output_name(name: str) -> str:
    problem = output_name_problem(name)
    if problem:
        raise ValueError(f"{name!r} {problem}: files are written inside the output folder "
                         "(--output); give a name relative to it")
    return name


#: A file (or folder) name relative to the run's output folder, checked at validation.
OutputName = Annotated[str, AfterValidator(_output_name)]


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
        target = (root / name).resolve()
        if output_name_problem(name) or not target.is_relative_to(root):
            raise OutputPathError(f"{self.ctx.id}: file {name!r} is outside the output "
                                  f"folder {root}")
        target.parent.mkdir(parents=True, exist_ok=True)
        return target

    @staticmethod
    def stream_slug(stream: str) -> str:
        return stream.replace(".", "_")
