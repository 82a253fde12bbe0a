"""Progress of a job of many runs: done / running / failed and an ETA.

:class:`Progress` only counts (and logs failures); :class:`BarProgress` draws a tqdm
bar on stderr (``runs 12/40 [01:10<02:45] running=2 failed=1``) and prints each
failure with its label and error above the bar; :class:`LineProgress` hands one line
per finished run to a callable (scripts, logs).
"""
from __future__ import annotations

import logging
import sys
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, TextIO

if TYPE_CHECKING:
    from .executor import Outcome, Task

log = logging.getLogger("firenav.scaleout")


class Progress:
    """Counts of a job; failures go to the log. Subclasses show them."""

    def __init__(self) -> None:
        self.total = 0
        self.done = 0
        self.failed = 0
        self.retried = 0
        self.active = 0

    def start(self, total: int, what: str = "runs") -> None:
        """A job of ``total`` tasks begins (tasks already done before a resume excluded)."""
        self.total, self.what = total, what

    def running(self, n: int) -> None:
        """``n`` tasks are being worked on now."""
        self.active = n

    def retrying(self, task: "Task", error: str) -> None:
        """``task`` failed on its first attempt and runs once more."""
        self.retried += 1
        self.note(f"{task.label} failed ({error}); trying once more")

    def finished(self, outcome: "Outcome") -> None:
        """A task is done: with a value, or failed after its retry."""
        self.done += 1
        if not outcome.ok:
            self.failed += 1
            self.note(f"{outcome.task.label} FAILED after {outcome.attempts} attempts: "
                      f"{outcome.error}")

    def note(self, text: str) -> None:
        log.warning(text)

    def close(self) -> None:
        """The job ended (done, failed or interrupted)."""

    def __enter__(self) -> "Progress":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class BarProgress(Progress):
    """A tqdm bar on ``stream`` (stderr): done/total, ETA, running and failed counts."""

    def __init__(self, stream: TextIO | None = None):
        super().__init__()
        self.stream = stream or sys.stderr
        self.bar = None

    def start(self, total: int, what: str = "runs") -> None:
        from tqdm import tqdm
        super().start(total, what)
        tty = getattr(self.stream, "isatty", lambda: False)()
        self.every_s = 0.5 if tty else 10.0   # a log file gets a line every 10 s at most
        self.bar = tqdm(total=total, desc=what, unit="run", file=self.stream,
                        dynamic_ncols=True, mininterval=self.every_s, smoothing=0.1)
        self._shown = 0.0
        self._postfix()

    def _postfix(self) -> None:
        if self.bar is None:
            return
        self.bar.set_postfix_str(f"running={self.active} failed={self.failed}", refresh=False)
        now = time.monotonic()
        if now - self._shown >= self.every_s:
            self.bar.refresh()
            self._shown = now

    def running(self, n: int) -> None:
        changed = n != self.active
        super().running(n)
        if changed:
            self._postfix()

    def finished(self, outcome: "Outcome") -> None:
        super().finished(outcome)
        if self.bar is not None:
            self.bar.update(1)
            self._postfix()

    def note(self, text: str) -> None:
        if self.bar is not None:
            self.bar.write(text, file=self.stream)
        else:
            print(text, file=self.stream, flush=True)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None


class LineProgress(Progress):
    """One line per finished (or failed) task, handed to ``say``."""

    def __init__(self, say: Callable[[str], None]):
        super().__init__()
        self.say = say

    def finished(self, outcome: "Outcome") -> None:
        super().finished(outcome)
        if outcome.ok:
            self.say(f"{outcome.task.label} ({self.done}/{self.total}, {outcome.wall_s:.1f} s)")

    def note(self, text: str) -> None:
        self.say(text)
