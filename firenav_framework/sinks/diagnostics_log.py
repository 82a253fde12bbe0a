"""The incident log: every diagnostic (alarms and acknowledgements included) as a JSON
line, flushed as it comes.

Each line has the pipeline time ``t`` [s] (on a live link the receive clock, UNIX
seconds) and, for a person, ``when``: that time on the local clock (``t=12.3 s`` in a
simulation, :mod:`..timefmt`); with ``wall_clock`` also ``wall``, the local wall-clock
time (ISO 8601 with the UTC offset) at which the line was written, so a replay's log
says both when it happened and when it was replayed. Alarm events (codes
``alarm_*``, :mod:`..liveview.alarms`) come from the ``live_view`` sink's
``diagnostics`` stream: name it in this sink's inputs.
"""
from __future__ import annotations

import json
from datetime import datetime

from ..contract import FileSink, OutputName, Params, param
from ..messages import Diagnostic
from ..timefmt import clock_text


class DiagnosticsLogSink(FileSink):
    """Append every diagnostic (alarms, acknowledgements) to a JSON-lines incident log."""

    name = "diagnostics_log"
    inputs = (Diagnostic,)

    class Params(Params):
        file: OutputName = param("diagnostics.jsonl")
        """file name under the output folder"""
        wall_clock: bool = param(True)
        """add the wall-clock time each line was written ('wall'); off: the file depends on the
        data only"""

    def start(self) -> None:
        self._fh = None

    def handle(self, stream: str, msg: Diagnostic) -> None:
        if self._fh is None:
            self._fh = open(self.out_path(self.params.file), "w", encoding="utf-8")
        line = {"t": msg.t, "when": clock_text(msg.t, date=True), "stream": stream,
                "component": msg.component, "agent": msg.agent, "level": msg.level,
                "code": msg.code, "active": msg.active, "text": msg.text}
        if self.params.wall_clock:
            line["wall"] = datetime.now().astimezone().isoformat(timespec="milliseconds")
        self._fh.write(json.dumps(line) + "\n")
        self._fh.flush()

    def finish(self) -> None:
        if self._fh is not None:
            self._fh.close()
