"""What every recorded-file reader shares: its options, its error type, IMU blocking.

See the package docstring (:mod:`firenav_framework.sources.readers`) for the reader
contract itself.
"""
from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass, field

import numpy as np

from ...messages import ImuBlock


class ReaderError(ValueError):
    """A file a reader cannot read: wrong content, missing variables, bad header.

    The message names the file and says what was expected, so the user can fix it.
    """


def _no_count(what: str, n: int = 1) -> None:
    """Default counter of :class:`ReadOptions`: nothing is recorded."""


@dataclass(frozen=True)
class ReadOptions:
    """How a reader labels and cuts what it reads.

    ``agent`` and ``device`` label messages whose file does not say (``device`` is
    ``"<agent>/imu"`` unless given); ``block_s`` is the length [s] of the
    :class:`ImuBlock` pieces an IMU recording is cut into; ``count(what, n)`` records
    rows or records the reader skipped (the recording source passes ``ctx.count``,
    so they appear in the run summary).
    """

    agent: str = "ff1"
    device: str = ""
    block_s: float = 0.1
    count: Callable[[str, int], None] = field(default=_no_count, compare=False)

    def __post_init__(self) -> None:
        if not self.device:
            object.__setattr__(self, "device", f"{self.agent}/imu")
        if not self.block_s > 0:
            raise ValueError(f"block_s must be positive, got {self.block_s}")


def imu_blocks(time: np.ndarray, accel: np.ndarray, gyro: np.ndarray, *, block_s: float,
               agent: str, device: str, frame: str = "device",
               mag: np.ndarray | None = None) -> Iterator[ImuBlock]:
    """Cut sample arrays into consecutive :class:`ImuBlock` pieces of about ``block_s``.

    Blocks follow the sample order (a recording's own order, even where its time
    steps back: judging samples is the sensor plugin's job, not the reader's).
    A block starts at every multiple of ``block_s`` after the first sample time;
    non-finite times stay in the block they arrive in. Arrays are ``(N,)`` and
    ``(N, 3)``, SI units, in the axes named by ``frame``.
    """
    n = len(time)
    if n == 0:
        return
    t0 = time[np.isfinite(time)][0] if np.isfinite(time).any() else 0.0
    slot = np.floor((time - t0) / block_s)
    # a sample whose slot differs from its predecessor's starts a new block; NaN
    # times never start one (NaN != x is True, so mask them explicitly)
    starts = np.flatnonzero((slot[1:] != slot[:-1]) & np.isfinite(slot[1:])) + 1
    bounds = np.concatenate(([0], starts, [n]))
    for a, b in zip(bounds[:-1], bounds[1:]):
        if b <= a:
            continue
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
