"""The record of every IMU codec: one inertial sample as the wire carried it.

IMU codecs (``can_imu``, ``mavlink_imu``, ``imu_lines`` and vendors' own) decode
frames into :class:`ImuSample` records and encode
:class:`~firenav_framework.messages.ImuBlock` s (device axes, SI units, the device's
clock in ``time``) into frames, so the ``foot_imu`` sensor and the player can use any
of them by name.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..messages import ImuBlock

__all__ = ["ImuSample", "check_device_times"]


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


def check_device_times(block: ImuBlock, protocol: str) -> np.ndarray:
    """The block's sample times [s] as floats; ``ValueError`` unless all are finite
    and non-negative (a device clock cannot send anything else)."""
    time = np.asarray(block.time, float)
    if len(time) and (not np.all(np.isfinite(time)) or time.min() < 0):
        raise ValueError(f"{protocol} times must be finite and non-negative (device clock)")
    return time
