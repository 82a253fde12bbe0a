"""Diagnostics as JSON lines, one object per diagnostic, flushed as they come."""
from __future__ import annotations

import json

from ..contract import FileSink, OutputName, Params, param
from ..messages import Diagnostic


class DiagnosticsLogSink(FileSink):
    """Append every diagnostic to a JSON-lines file for the incident log."""

    name = "diagnostics_log"
    inputs = (Diagnostic,)

    class Params(Params):
        file: OutputName = param("diagnostics.jsonl", description="file name under the output folder")

    def start(self) -> None:
        self._fh = None

    def handle(self, stream: str, msg: Diagnostic) -> None:
        if self._fh is None:
            self._fh = open(self.out_path(self.params.file), "w", encoding="utf-8")
        self._fh.write(json.dumps({"t": msg.t, "stream": stream, "component": msg.component,
                                   "agent": msg.agent, "level": msg.level, "code": msg.code,
                                   "active": msg.active, "text": msg.text}) + "\n")
        self._fh.flush()

    def finish(self) -> None:
        if self._fh is not None:
            self._fh.close()
