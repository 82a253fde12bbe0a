"""One device's samples as arrays, collecting decoded samples into them, and holding back
a last sample that leaps ahead."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from firenav_framework.codecs.imu_sample import ImuSample

__all__ = ["Samples", "SampleBuffer", "hold_leap", "MAX_BUFFER"]

#: Samples collected from frames before a block is forced out.
MAX_BUFFER = 4096
_NO_MAG = (np.nan,) * 3


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


class SampleBuffer:
    """Collects one device's decoded samples into blocks of about ``block_s`` seconds.

    :meth:`add` returns the samples collected so far once a sample lies ``block_s`` or
    more from the first finite time collected (or :data:`MAX_BUFFER` samples wait),
    before keeping the new one.
    """

    def __init__(self, block_s: float):
        self.block_s = block_s
        self._rows: list[tuple] = []
        self._t0: float | None = None   # first finite sample time collected

    def add(self, t: float, sample: ImuSample) -> Samples | None:
        """Keep ``sample`` at pipeline time ``t`` [s]; the previous block if it is complete."""
        done = None
        if (self._t0 is not None and abs(t - self._t0) >= self.block_s
                or len(self._rows) >= MAX_BUFFER):
            done = self.take()
        if self._t0 is None and np.isfinite(t):
            self._t0 = t
        self._rows.append((t, *sample.accel, *sample.gyro, *(sample.mag or _NO_MAG),
                           sample.flags))
        return done

    def take(self) -> Samples | None:
        """Everything collected (None if nothing), emptying the buffer."""
        if not self._rows:
            return None
        rows = np.array(self._rows, dtype=float)
        self._rows, self._t0 = [], None
        mag = rows[:, 7:10]
        return Samples(rows[:, 0], rows[:, 1:4], rows[:, 4:7],
                       None if np.isnan(mag).all() else mag, rows[:, 10].astype(np.uint8))


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
