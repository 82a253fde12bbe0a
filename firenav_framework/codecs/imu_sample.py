"""The record of every IMU codec: one inertial sample as the wire carried it.

IMU codecs (``can_imu``, ``mavlink_imu``, ``imu_lines`` and vendors' own) decode
frames into :class:`ImuSample` records and encode
:class:`~firenav_framework.messages.ImuBlock` s (device axes, SI units, the device's
clock in ``time``) into frames, so the ``foot_imu`` sensor and the player can use any
of them by name.
"""
from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ..messages import ImuBlock

__all__ = ["ImuSample", "ImuSamples", "check_device_times"]


class ImuSample(NamedTuple):
    """One IMU sample decoded from frames: device axes, SI units, device clock.

    ``device`` is the raw device id (``<bus>/node<n>``, ``sys<s>/comp<c>/imu<i>``, a
    port name: what ``agent_map`` and calibration files match); ``flags`` holds the
    :data:`~firenav_framework.messages.IMU_FLAG_BITS` the frames already tell
    (a saturated reading).
    """

    device: str
    t: float                                       # device time [s]
    accel: tuple[float, float, float]              # specific force [m/s^2]
    gyro: tuple[float, float, float]               # angular rate [rad/s]
    mag: tuple[float, float, float] | None = None  # magnetic field [uT]
    flags: int = 0


@dataclass(frozen=True)
class ImuSamples(Sequence):
    """Many :class:`ImuSample` records as arrays, in frame order: what an IMU codec's
    :meth:`~firenav_framework.codecs.base.Codec.decode_batch` returns.

    ``device`` (n,) raw device ids; ``t`` (n,) device time [s]; ``accel`` (n, 3)
    [m/s^2]; ``gyro`` (n, 3) [rad/s]; ``mag`` (n, 3) [uT], NaN rows for samples without
    one (None: no sample has one); ``flags`` (n,) uint8. Indexing gives the records.
    """

    device: Sequence[str]
    t: np.ndarray
    accel: np.ndarray
    gyro: np.ndarray
    mag: np.ndarray | None
    flags: np.ndarray

    def __len__(self) -> int:
        return len(self.t)

    def __getitem__(self, i):  # type: ignore[override]
        if isinstance(i, slice):
            raise TypeError("ImuSamples: index one record, or use take()")
        mag = None if self.mag is None or np.isnan(self.mag[i]).all() else tuple(
            self.mag[i].tolist())
        return ImuSample(self.device[i], float(self.t[i]), tuple(self.accel[i].tolist()),
                         tuple(self.gyro[i].tolist()), mag, int(self.flags[i]))

    def __iter__(self) -> Iterator[ImuSample]:
        return (self[i] for i in range(len(self)))

    def take(self, index: np.ndarray) -> "ImuSamples":
        """The records at ``index`` (an index or boolean array), in that order."""
        index = np.asarray(index)
        if index.dtype == bool:
            index = np.flatnonzero(index)
        device = [self.device[i] for i in index.tolist()]
        return ImuSamples(device, self.t[index], self.accel[index], self.gyro[index],
                          None if self.mag is None else self.mag[index], self.flags[index])

    @classmethod
    def from_records(cls, records: Sequence[ImuSample]) -> "ImuSamples":
        """Arrays of ``records`` (a codec's per-frame output)."""
        if isinstance(records, ImuSamples):
            return records
        n = len(records)
        mag = None
        if any(r.mag is not None for r in records):
            mag = np.array([r.mag if r.mag is not None else (np.nan,) * 3 for r in records],
                           float).reshape(n, 3)
        return cls([r.device for r in records], np.array([r.t for r in records], float),
                   np.array([r.accel for r in records], float).reshape(n, 3),
                   np.array([r.gyro for r in records], float).reshape(n, 3), mag,
                   np.array([r.flags for r in records], np.uint8))

    @classmethod
    def merge(cls, parts: Sequence[tuple[np.ndarray, "ImuSamples"]]
              ) -> tuple["ImuSamples", np.ndarray]:
        """One batch of several, ordered by the frame index each record came from, and
        those indices (``parts``: (frame index per record, records); stable for equal
        indices)."""
        parts = [(np.asarray(i, np.int64), p) for i, p in parts if len(p)]
        if not parts:
            return cls.from_records([]), np.zeros(0, np.int64)
        if len(parts) == 1:
            return parts[0][1], parts[0][0]
        index = np.concatenate([i for i, _ in parts])
        order = np.argsort(index, kind="stable")
        device = [d for _, p in parts for d in p.device]
        mag = None
        if any(p.mag is not None for _, p in parts):
            mag = np.concatenate([np.full((len(p), 3), np.nan) if p.mag is None else p.mag
                                  for _, p in parts])[order]
        merged = cls([device[k] for k in order.tolist()],
                     np.concatenate([p.t for _, p in parts])[order],
                     np.concatenate([p.accel for _, p in parts])[order],
                     np.concatenate([p.gyro for _, p in parts])[order], mag,
                     np.concatenate([p.flags for _, p in parts])[order])
        return merged, index[order]


def check_device_times(block: ImuBlock, protocol: str) -> np.ndarray:
    """The block's sample times [s] as floats; ``ValueError`` unless all are finite
    and non-negative (a device clock cannot send anything else)."""
    time = np.asarray(block.time, float)
    if len(time) and (not np.all(np.isfinite(time)) or time.min() < 0):
        raise ValueError(f"{protocol} times must be finite and non-negative (device clock)")
    return time
