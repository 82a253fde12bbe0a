"""What every recorded-file reader shares: its options, its error type, IMU blocking and
reading a text recording in chunks.

See :mod:`firenav_framework.sources.readers` for the reader contract itself and the
table of readers by file suffix.
"""
from __future__ import annotations

import heapq
import itertools
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..messages import ImuBlock, Message

if TYPE_CHECKING:
    from .csv_layout import CsvColumns


class ReaderError(ValueError):
    """A file a reader cannot read: wrong content, missing variables, bad header.

    The message names the file and says what was expected, so the user can fix it.
    """


def _no_count(what: str, n: int = 1) -> None:
    """Default counter of :class:`ReadOptions`: nothing is recorded."""


def _no_warn(code: str, text: str) -> None:
    """Default warning callback of :class:`ReadOptions`: nothing is reported."""


@dataclass(frozen=True)
class ReadOptions:
    """How a reader labels and cuts what it reads.

    ``agent`` and ``device`` label messages whose file does not say (``device`` is
    ``"<agent>/imu"`` unless given); ``block_s`` is the length [s] of the
    :class:`ImuBlock` pieces an IMU recording is cut into; ``count(what, n)`` records
    rows or records the reader skipped (the recording source passes ``ctx.count``,
    so they appear in the run summary); ``warn(code, text)`` reports what the user
    must hear about once (an empty log, a damaged region, a file of one device that
    cannot be read), with the file in the text; ``columns`` is the column and unit
    mapping of a text recording (a :class:`~.csv_layout.CsvColumns`, None: from the file).
    """

    agent: str = "ff1"
    device: str = ""
    block_s: float = 0.1
    count: Callable[[str, int], None] = field(default=_no_count, compare=False)
    warn: Callable[[str, str], None] = field(default=_no_warn, compare=False)
    columns: CsvColumns | None = None

    def __post_init__(self) -> None:
        if not self.device:
            object.__setattr__(self, "device", f"{self.agent}/imu")
        if not self.block_s > 0:
            raise ValueError(f"block_s must be positive, got {self.block_s}")


def imu_blocks(time: np.ndarray, accel: np.ndarray, gyro: np.ndarray, *, block_s: float,
               agent: str, device: str, frame: str = "device",
               mag: np.ndarray | None = None) -> Iterator[ImuBlock]:
    """Cut sample arrays into consecutive :class:`ImuBlock` pieces of about ``block_s``.

    Each piece holds ``block_s`` over the median sample interval samples, in the
    recording's own order: a corrupt or repeated timestamp then stays inside a block
    instead of starting one of its own (judging samples is the sensor plugin's job,
    not the reader's). Arrays are ``(N,)`` and ``(N, 3)``, SI units, in the axes
    named by ``frame``.
    """
    n = len(time)
    if n == 0:
        return
    steps = np.diff(time)
    steps = steps[np.isfinite(steps) & (steps > 0)]
    per = max(1, int(round(block_s / float(np.median(steps))))) if steps.size else n
    for a in range(0, n, per):
        b = min(a + per, n)
        yield ImuBlock(t=_block_time(time[a:b]), agent=agent, device=device,
                       time=time[a:b], accel=accel[a:b], gyro=gyro[a:b],
                       mag=None if mag is None else mag[a:b], frame=frame)


def _block_time(time: np.ndarray) -> float:
    """``t`` of a block: its last sample time, or the last finite one if that is bad."""
    last = float(time[-1])
    if np.isfinite(last):
        return last
    finite = time[np.isfinite(time)]
    return float(finite[-1]) if finite.size else last


def chunked_imu(path: Path, skip_lines: int, chunk_rows: int,
                parse: Callable[[list[str]], list[list[ImuBlock]]]
                ) -> Iterator[tuple[str, Message]]:
    """``("imu", block)`` of a text recording, in bounded memory: after ``skip_lines``
    header lines, ``chunk_rows`` lines at a time go to ``parse`` (one time-ordered block
    list per device), whose lists are merged in time order."""
    with open(path, encoding="utf-8", errors="replace", newline="") as fh:
        for _ in range(skip_lines):
            fh.readline()
        while True:
            lines = list(itertools.islice(fh, chunk_rows))
            if not lines:
                return
            yield from (("imu", b) for b in heapq.merge(*parse(lines), key=lambda b: b.t))
