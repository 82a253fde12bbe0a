"""A vendor's wire protocol, shipped as a codec only (no sensor): the ACME AX-2 foot IMU.

Each sample is two classic CAN frames of node n: ``0x300 + 0x10 n`` carries the
specific force (3 x int16, 0.01 m/s^2) and ``0x301 + 0x10 n`` the angular rate
(3 x int16, 0.001 rad/s), both followed by the sample tick (uint16, the device clock in
milliseconds, wrapping every 65.536 s). A vendor registers it under the
``firenav.codecs`` entry-point group; the tests do the same with a monkeypatched entry
point.
"""
from __future__ import annotations

import struct

import numpy as np

from firenav_framework.codecs import Codec, EncodedFrame, FrameError
from firenav_framework.codecs.imu_sample import ImuSample
from firenav_framework.contract import param
from firenav_framework.messages import ImuBlock, RawFrame

BASE = 0x300
ACCEL_LSB, GYRO_LSB = 0.01, 0.001      # m/s^2, rad/s per count
_FRAME = struct.Struct("<hhhH")


class AcmeCanImuCodec(Codec):
    """ACME AX-2 foot IMU on CAN: accel and gyro frames per sample, a 1 ms tick."""

    name = "acme_can_imu"
    transport = "can"
    record = ImuSample

    class Options(Codec.Options):
        nodes: int = param(2, ge=1, le=16)
        """IMU nodes on the bus"""

    def __init__(self, options=None, **kw):
        super().__init__(options, **kw)
        self._half: dict[tuple[str, int], dict[str, tuple]] = {}   # (device, tick) -> parts
        self._clock: dict[str, tuple[int, int]] = {}                # device -> (tick, wraps)

    def addresses(self) -> list[str]:
        return [f"node{n}" for n in range(self.options.nodes)]

    def channels(self, address: str) -> list[int]:
        n = self.addresses().index(address)
        return [BASE + 0x10 * n, BASE + 0x10 * n + 1]

    def decode(self, frame: RawFrame) -> list[ImuSample] | None:
        fid = frame.channel
        if not isinstance(fid, int) or not 0 <= fid - BASE < 0x10 * self.options.nodes \
                or fid & 0xF > 1:
            return None
        if len(frame.data) != _FRAME.size:
            raise FrameError("bad_frames", f"ACME frame 0x{fid:X} has {len(frame.data)} bytes")
        x, y, z, tick = _FRAME.unpack(frame.data)
        device = f"{frame.device}/node{(fid - BASE) >> 4}"
        parts = self._half.setdefault((device, tick), {})
        parts["gyro" if fid & 1 else "accel"] = (x, y, z)
        if len(parts) < 2:
            return []
        del self._half[(device, tick)]
        a, g = parts["accel"], parts["gyro"]
        return [ImuSample(device, self._unwrap(device, tick) * 1e-3,
                          tuple(v * ACCEL_LSB for v in a), tuple(v * GYRO_LSB for v in g))]

    def _unwrap(self, device: str, tick: int) -> int:
        last, wraps = self._clock.get(device, (tick, 0))
        if tick < last - 32768:
            wraps += 1
        self._clock[device] = (tick, wraps)
        return tick + 65536 * wraps

    def encode(self, block: ImuBlock, *, address: str = "") -> list[EncodedFrame]:
        accel_id, gyro_id = self.channels(address or "node0")
        ticks = np.round(np.asarray(block.time) * 1e3).astype(np.int64) % 65536
        a = np.clip(np.round(block.accel / ACCEL_LSB), -32768, 32767).astype(int)
        g = np.clip(np.round(block.gyro / GYRO_LSB), -32768, 32767).astype(int)
        out = []
        for t, tick, av, gv in zip(block.time.tolist(), ticks.tolist(), a.tolist(), g.tolist()):
            out.append(EncodedFrame(t, accel_id, _FRAME.pack(*av, tick)))
            out.append(EncodedFrame(t, gyro_id, _FRAME.pack(*gv, tick)))
        return out
