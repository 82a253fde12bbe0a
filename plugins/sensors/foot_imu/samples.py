"""One device's samples as arrays, the frames of one link device collected for decoding
in batches, and holding back a last sample that leaps ahead."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from firenav_framework.messages import RawFrame

__all__ = ["Samples", "FrameBatch", "hold_leap", "MAX_BUFFER"]

#: Frames collected before a batch is decoded regardless of their times.
MAX_BUFFER = 4096


@dataclass(frozen=True)
class Samples:
    """One device's samples in arrival order: SI units, device axes."""

    time: np.ndarray                # (n,) s
    accel: np.ndarray               # (n, 3) m/s^2
    gyro: np.ndarray                # (n, 3) rad/s
    mag: np.ndarray | None          # (n, 3) uT
    flags: np.ndarray               # (n,) uint8

    def __len__(self) -> int:
        return len(self.time)

    def take(self, index: np.ndarray | slice) -> "Samples":
        return Samples(self.time[index], self.accel[index], self.gyro[index],
                       None if self.mag is None else self.mag[index], self.flags[index])

    def then(self, later: "Samples") -> "Samples":
        """These samples followed by ``later``."""
        mag = None
        if self.mag is not None or later.mag is not None:
            mag = np.concatenate([np.full((len(x), 3), np.nan) if x.mag is None else x.mag
                                  for x in (self, later)])
        return Samples(np.concatenate((self.time, later.time)),
                       np.concatenate((self.accel, later.accel)),
                       np.concatenate((self.gyro, later.gyro)), mag,
                       np.concatenate((self.flags, later.flags)))


class FrameBatch:
    """Frames of one link device, waiting to be decoded together.

    :meth:`add` returns the frames collected so far once a frame arrives ``block_s``
    or more (frame time) after the first one collected, or :data:`MAX_BUFFER` frames
    wait, before keeping the new one: a block is out as soon as it is complete, and a
    backlog that arrives at once (a link that stalled) is decoded as one batch.
    """

    def __init__(self, block_s: float):
        self.block_s = block_s
        self.frames: list[RawFrame] = []
        self.agents: set[str] = set()   # firefighters whose samples these frames carried
        self._t0 = math.nan   # frame time of the first frame collected

    def add(self, frame: RawFrame) -> list[RawFrame] | None:
        done = None
        if self.frames and (abs(frame.t - self._t0) >= self.block_s
                            or len(self.frames) >= MAX_BUFFER):
            done = self.take()
        if not self.frames or not math.isfinite(self._t0):
            self._t0 = frame.t
        self.frames.append(frame)
        return done

    def take(self) -> list[RawFrame] | None:
        """Everything collected (None if nothing), emptying the batch."""
        if not self.frames:
            return None
        done, self.frames, self._t0 = self.frames, [], math.nan
        return done


def hold_leap(samples: Samples, last_t: float, gap: float) -> tuple[Samples, Samples | None]:
    """Split off a last sample that leaps more than ``gap`` [s] ahead of its predecessor.

    Only the sample after it can tell a real gap from a corrupt timestamp (see
    ``time_outlier`` in :mod:`.screening`), so it waits for the device's next input.
    ``last_t`` is the device's newest kept sample time before these.
    """
    t = samples.time
    if not len(t) or not np.isfinite(t[-1]):
        return samples, None
    before = t[:-1][np.isfinite(t[:-1])]
    prev = before[-1] if before.size else last_t
    if np.isfinite(prev) and t[-1] - prev > gap:
        return samples.take(slice(0, -1)), samples.take(slice(-1, None))
    return samples, None
