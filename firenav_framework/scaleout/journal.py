"""Results appended as they arrive (JSON lines), so an interrupted job resumes.

Each finished task writes one line ``{"key": ..., "ok": true|false, ...}`` and the
file is flushed to disk before the next result is taken, so a job killed at any
moment loses at most the runs that were in flight. On restart :meth:`Journal.done`
gives the keys whose result is kept; tasks that failed are run again (their failure
may have been the machine's). A last line cut off by the interruption is skipped
and counted in :attr:`Journal.damaged`.
"""
from __future__ import annotations

import json
import logging
import os
from pathlib import Path
from typing import Any

log = logging.getLogger("firenav.scaleout")


class Journal:
    """An append-only JSON-lines file of task results, keyed by task key."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self.damaged = 0
        self.records: dict[str, dict[str, Any]] = {}
        self._cut = False      # the file ends inside a line: start the next one afresh
        if self.path.exists():
            self._read()

    def _read(self) -> None:
        with self.path.open("rb") as fh:
            fh.seek(0, os.SEEK_END)
            if fh.tell():
                fh.seek(-1, os.SEEK_END)
                self._cut = fh.read(1) != b"\n"
        with self.path.open(encoding="utf-8", errors="replace") as fh:
            for lineno, line in enumerate(fh, 1):
                if not line.strip():
                    continue
                try:
                    rec = json.loads(line)
                    key = rec["key"]
                except (ValueError, KeyError, TypeError):
                    self.damaged += 1
                    log.warning("%s:%d: unreadable result line skipped (the job was probably "
                                "interrupted while writing it); that run is done again",
                                self.path, lineno)
                    continue
                self.records[key] = rec

    def done(self) -> set[str]:
        """Keys of tasks whose successful result is in the journal."""
        return {k for k, r in self.records.items() if r.get("ok")}

    def append(self, record: dict[str, Any]) -> None:
        """Add one result (must have ``key`` and ``ok``) and make it durable."""
        self.path.parent.mkdir(parents=True, exist_ok=True)
        line = ("\n" if self._cut else "") + json.dumps(record, default=json_default) + "\n"
        self._cut = False
        with self.path.open("a", encoding="utf-8") as fh:
            fh.write(line)
            fh.flush()
            os.fsync(fh.fileno())
        self.records[record["key"]] = record


def json_default(v: Any) -> Any:
    """``json.dumps(default=...)`` for numpy scalars."""
    import numpy as np
    if isinstance(v, np.generic):
        return v.item()
    raise TypeError(f"not JSON serialisable: {type(v).__name__}")
