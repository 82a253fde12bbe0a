"""Shared behaviour of file-writing sinks: where their files go."""
from __future__ import annotations

from pathlib import Path

from ..components import Sink


class FileSink(Sink):
    """A sink that writes files under the run's output folder (``--output``)."""

    def out_path(self, name: str) -> Path:
        """``name`` relative to the output folder (created on demand); absolute stays."""
        p = Path(name).expanduser()
        if not p.is_absolute():
            p = (self.ctx.output_dir or Path("out")) / p
        p.parent.mkdir(parents=True, exist_ok=True)
        return p

    @staticmethod
    def stream_slug(stream: str) -> str:
        return stream.replace(".", "_")
