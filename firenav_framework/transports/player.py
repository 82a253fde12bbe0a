"""Plays IMU data onto live links as the real devices would (simulator, tests, benchmarks).

Each IMU device is assigned a link: a CAN node of the reference DBC layout (frames
from ``firenav_plugins.sensors.imu_can.encode_can_imu``: ACCEL, GYRO, TIME per
sample, ids ``0x100 + 0x10 * node``) or a MAVLink system and IMU id (HIGHRES_IMU
packets from ``firenav_plugins.sensors.imu_mavlink.encode_mavlink_imu``). Blocks are
sent when the wall clock reaches their time (``speed`` times faster), so the field
kit receives them at the pace a real device sends them. Encoding is the sensor
plugins' job; the player only moves frames.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import can
import numpy as np

from ..messages import ImuBlock


@dataclass
class Assignment:
    """Where one device's samples go: ``("can", node)`` or ``("mavlink", sysid, imu_id)``."""

    link: str
    node: int = 0
    sysid: int = 1
    imu_id: int = 0


@dataclass
class DevicePlayer:
    """Sends ImuBlocks of assigned devices onto a CAN bus and/or a MAVLink connection."""

    can_bus: can.BusABC | None = None
    mavlink: Any = None  # a pymavlink connection (anything with write(bytes))
    assignments: dict[str, Assignment] = field(default_factory=dict)
    speed: float = 1.0
    sent: dict[str, int] = field(default_factory=lambda: {"can": 0, "mavlink": 0})
    _t0: tuple[float, float] | None = None
    _seq: dict[str, int] = field(default_factory=dict)

    def pace(self, t: float) -> None:
        """Wait until the wall clock reaches data time ``t`` [s] (scaled by ``speed``)."""
        if self.speed <= 0:
            return
        if self._t0 is None:
            self._t0 = (time.monotonic(), t)
        delay = self._t0[0] + (t - self._t0[1]) / self.speed - time.monotonic()
        if delay > 0:
            time.sleep(delay)

    def send(self, block: ImuBlock) -> int:
        """Encode and send one block of its device's link; returns frames sent."""
        a = self.assignments.get(block.device)
        if a is None:
            return 0
        seq = self._seq.get(block.device, 0)
        self._seq[block.device] = seq + len(block)
        t = np.asarray(block.time, float)
        if a.link == "can":
            from firenav_plugins.sensors.imu_can import encode_can_imu
            frames = encode_can_imu(t, block.accel, block.gyro, node=a.node, seq_start=seq)
            for f in frames:
                self.can_bus.send(can.Message(arbitration_id=f.channel, data=f.data,
                                              is_extended_id=False))
        else:
            from firenav_plugins.sensors.imu_mavlink import encode_mavlink_imu
            frames = encode_mavlink_imu(t, block.accel, block.gyro, sysid=a.sysid,
                                        imu_id=a.imu_id, seq_start=seq)
            for f in frames:
                self.mavlink.write(f.data)
        self.sent[a.link] += len(frames)
        return len(frames)
