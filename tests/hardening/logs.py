"""Field logs of a simulated two-firefighter walk, as the live sources write them."""
from __future__ import annotations

import random
import struct
from pathlib import Path

import can
import numpy as np

from firenav_framework.codecs.can_imu import CanImuCodec
from firenav_framework.codecs.mavlink_imu import MavlinkImuCodec
from firenav_framework.formats.base import ReadOptions
from firenav_framework.formats.imu_csv import ImuCsvReader
from firenav_framework.messages import ImuBlock

T0_US = 1_700_000_000_000_000  # UNIX receive times, as a live link stamps them
FLU_TO_FRD = np.diag([1.0, -1.0, -1.0])


def device_blocks(sim: Path) -> dict[str, ImuBlock]:
    """Each firefighter's whole IMU recording as one FRD block (device axes)."""
    out = {}
    for agent in ("ff1", "ff2"):
        blocks = [b for _, b in ImuCsvReader(sim / f"imu_{agent}.csv", ReadOptions(block_s=1))]
        time = np.concatenate([b.time for b in blocks])
        out[agent] = ImuBlock.from_arrays(time, np.vstack([b.accel for b in blocks]) @ FLU_TO_FRD,
                                          np.vstack([b.gyro for b in blocks]) @ FLU_TO_FRD,
                                          frame="FRD")
    return out


def write_tlog(sim: Path, path: Path) -> int:
    """HIGHRES_IMU of ff1 (system 1) and ff2 (system 2); returns the record count."""
    codec, records = MavlinkImuCodec(), []
    for sysid, block in enumerate(device_blocks(sim).values(), start=1):
        for f in codec.encode(block, address=f"sys{sysid}/comp1/imu0"):
            records.append((T0_US + round(f.t * 1e6), sysid, f.data))
    records.sort()
    path.write_bytes(b"".join(struct.pack(">Q", us) + data for us, _, data in records))
    return len(records)


def write_can_log(sim: Path, path: Path, max_container: int | None = None) -> int:
    """IMU frames of ff1 (node 1) and ff2 (node 2) in the python-can format of ``path``."""
    codec, msgs = CanImuCodec(), []
    for node, block in enumerate(device_blocks(sim).values(), start=1):
        for f in codec.encode(block, address=f"node{node}"):
            msgs.append(can.Message(timestamp=T0_US / 1e6 + f.t, arbitration_id=f.channel,
                                    data=f.data, channel="can0", is_extended_id=False))
    msgs.sort(key=lambda m: m.timestamp)
    writer = can.Logger(str(path))
    if max_container:
        writer.max_container_size = max_container
    for m in msgs:
        writer.on_message_received(m)
    writer.stop()
    return len(msgs)


def damage(path: Path, n: int = 4096, at: float = 0.5, seed: int = 1) -> None:
    """Insert ``n`` random bytes at fraction ``at`` of the file."""
    data = path.read_bytes()
    k = int(len(data) * at)
    rnd = random.Random(seed)
    path.write_bytes(data[:k] + bytes(rnd.randrange(256) for _ in range(n)) + data[k:])
