"""MAVLink codec for IMU messages: HIGHRES_IMU, SCALED_IMU(2, 3) and RAW_IMU.

Packets are built and parsed with pymavlink's generated MAVLink 2 dialect
(``pymavlink.dialects.v20.common``, imported directly, so no ``MAVLINK20``
environment variable is needed; the v2 parser also reads MAVLink 1 packets).

=============  ====  ==================================  ===========================
message        id    units on the wire                   IMU index / time
=============  ====  ==================================  ===========================
HIGHRES_IMU    105   float m/s^2, rad/s, gauss           ``id`` field; ``time_usec``
SCALED_IMU     26    int16 milli-g, mrad/s, milligauss   0; ``time_boot_ms``
SCALED_IMU2    116   as SCALED_IMU                       1
SCALED_IMU3    129   as SCALED_IMU                       2
RAW_IMU        27    int16 raw counts (scales needed)    ``id`` field; ``time_usec``
=============  ====  ==================================  ===========================

MAVLink's body frame is FRD (x forward, y right, z down), and its accelerometers
report specific force (about -9.81 m/s^2 on z at rest): a device that follows it
is mapped to FLU with the sensor's ``axes: [x, -y, -z]``. int16 values at either
end of their range are flagged saturated; an all-zero magnetometer field means the
device has none.
"""
from __future__ import annotations

import functools
from typing import Any

import numpy as np

from firenav_framework.messages import IMU_FLAG_BITS, RawFrame

from .imu_frames import DecodedSample, EncodedFrame, FrameError

__all__ = ["MAVLINK_IMU_IDS", "encode_mavlink_imu", "MavlinkImuDecoder", "G0"]

G0 = 9.80665  # m/s^2 per g: MAVLink's milli-g
GAUSS_UT = 100.0  # uT per gauss

#: Message ids of the IMU messages (SCALED_IMU covers SCALED_IMU2 and 3).
MAVLINK_IMU_IDS = {"HIGHRES_IMU": 105, "SCALED_IMU": 26, "SCALED_IMU2": 116,
                   "SCALED_IMU3": 129, "RAW_IMU": 27}
_SCALED = ("SCALED_IMU", "SCALED_IMU2", "SCALED_IMU3")
_INT16 = (-32768, 32767)
_HIGHRES_ACCEL_GYRO = 0x3F   # fields_updated bits of xacc..zgyro
_HIGHRES_MAG = 0x1C0         # fields_updated bits of xmag..zmag
_SATURATED = IMU_FLAG_BITS["saturated"]


@functools.lru_cache(maxsize=1)
def _dialect() -> Any:
    from pymavlink.dialects.v20 import common

    return common


def encode_mavlink_imu(time: np.ndarray, accel: np.ndarray, gyro: np.ndarray, *,
                       message: str = "HIGHRES_IMU", imu_id: int = 0, sysid: int = 1,
                       compid: int = 1, mag: np.ndarray | None = None, seq_start: int = 0,
                       raw_accel_scale: float | None = None, raw_gyro_scale: float | None = None,
                       raw_mag_scale: float | None = None) -> list[EncodedFrame]:
    """Encode samples as complete MAVLink 2 packets (``RawFrame.data`` of the link).

    ``time`` (N,) device clock [s] (>= 0), ``accel`` (N, 3) [m/s^2], ``gyro`` (N, 3)
    [rad/s], ``mag`` (N, 3) [uT] or None, in the device axes (FRD for MAVLink).
    ``message`` is HIGHRES_IMU, SCALED_IMU or RAW_IMU; for SCALED_IMU ``imu_id``
    1 and 2 select SCALED_IMU2/3. RAW_IMU needs ``raw_accel_scale`` [m/s^2 per
    count] and ``raw_gyro_scale`` [rad/s per count] (and ``raw_mag_scale`` [uT per
    count] with ``mag``). int16 fields are rounded and clipped to their range.
    """
    mav_mod = _dialect()
    mav = mav_mod.MAVLink(None, srcSystem=sysid, srcComponent=compid)
    mav.seq = seq_start & 0xFF
    time = np.asarray(time, float)
    if len(time) and (not np.all(np.isfinite(time)) or time.min() < 0):
        raise ValueError("MAVLink IMU times must be finite and non-negative (device clock)")
    n = len(time)
    mag_arr = np.zeros((n, 3)) if mag is None else np.asarray(mag, float)
    if message == "HIGHRES_IMU":
        updated = _HIGHRES_ACCEL_GYRO | (0 if mag is None else _HIGHRES_MAG)
        usec = np.round(time * 1e6).astype(np.int64).tolist()
        rows = np.hstack((accel, gyro, mag_arr / GAUSS_UT)).tolist()
        msgs = [mav_mod.MAVLink_highres_imu_message(u, *r, 0.0, 0.0, 0.0, 0.0, updated, imu_id)
                for u, r in zip(usec, rows)]
        msgid = MAVLINK_IMU_IDS[message]
    elif message == "SCALED_IMU":
        if not 0 <= imu_id <= 2:
            raise ValueError("SCALED_IMU carries IMUs 0..2 (SCALED_IMU, SCALED_IMU2, SCALED_IMU3)")
        name = _SCALED[imu_id]
        cls = getattr(mav_mod, f"MAVLink_{name.lower()}_message")
        ms = (np.round(time * 1e3).astype(np.int64) % (1 << 32)).tolist()
        ints = _int16(np.hstack((accel / G0 * 1e3, gyro * 1e3, mag_arr * 10.0))).tolist()
        msgs = [cls(m, *r, 0) for m, r in zip(ms, ints)]
        msgid = MAVLINK_IMU_IDS[name]
    elif message == "RAW_IMU":
        if raw_accel_scale is None or raw_gyro_scale is None or (
                mag is not None and raw_mag_scale is None):
            raise ValueError("RAW_IMU needs raw_accel_scale and raw_gyro_scale (and "
                             "raw_mag_scale with mag)")
        usec = np.round(time * 1e6).astype(np.int64).tolist()
        ints = _int16(np.hstack((accel / raw_accel_scale, gyro / raw_gyro_scale,
                                 mag_arr / (raw_mag_scale or 1.0)))).tolist()
        msgs = [mav_mod.MAVLink_raw_imu_message(u, *r, imu_id, 0) for u, r in zip(usec, ints)]
        msgid = MAVLINK_IMU_IDS[message]
    else:
        raise ValueError(f"message must be HIGHRES_IMU, SCALED_IMU or RAW_IMU, not {message!r}")
    return [EncodedFrame(t, msgid, bytes(m.pack(mav))) for t, m in zip(time.tolist(), msgs)]


def _int16(v: np.ndarray) -> np.ndarray:
    return np.clip(np.round(v), *_INT16).astype(np.int64)


class MavlinkImuDecoder:
    """Decodes IMU packets of a MAVLink link into samples (see the module docstring).

    ``messages`` selects which of HIGHRES_IMU, SCALED_IMU (with 2 and 3) and RAW_IMU
    are used: list only one of them for a device that sends the same IMU as
    several (they would otherwise be merged into one sample stream). RAW_IMU
    needs ``raw_accel_scale`` [m/s^2 per count] and ``raw_gyro_scale`` [rad/s per
    count]; without them its packets raise :class:`FrameError` ``raw_imu_unscaled``.
    Other message ids are not IMU frames (``None``).
    """

    def __init__(self, messages: tuple[str, ...] = ("HIGHRES_IMU", "SCALED_IMU", "RAW_IMU"),
                 raw_accel_scale: float | None = None, raw_gyro_scale: float | None = None,
                 raw_mag_scale: float | None = None):
        names = set(messages) | ({"SCALED_IMU2", "SCALED_IMU3"} if "SCALED_IMU" in messages
                                 else set())
        unknown = names - set(MAVLINK_IMU_IDS)
        if unknown:
            raise ValueError(f"unknown MAVLink IMU messages {sorted(unknown)}")
        self.ids = {MAVLINK_IMU_IDS[n] for n in names}
        self.raw_scales = (raw_accel_scale, raw_gyro_scale, raw_mag_scale)
        self._parser = _dialect().MAVLink(None)

    def decode(self, frame: RawFrame) -> list[DecodedSample] | None:
        if frame.channel not in self.ids:
            return None
        try:
            msg = self._parser.decode(bytearray(frame.data))
        except Exception as exc:  # pymavlink raises MAVError, struct.error, IndexError ...
            raise FrameError("bad_frames", f"MAVLink msgid {frame.channel}: {exc}") from None
        name = msg.get_type()
        if MAVLINK_IMU_IDS.get(name) != frame.channel:
            raise FrameError("bad_frames", f"packet holds {name}, but the frame says msgid "
                             f"{frame.channel}")
        source = f"sys{msg.get_srcSystem()}/comp{msg.get_srcComponent()}"
        if name == "HIGHRES_IMU":
            mag = None
            if msg.fields_updated & _HIGHRES_MAG == _HIGHRES_MAG:
                mag = (msg.xmag * GAUSS_UT, msg.ymag * GAUSS_UT, msg.zmag * GAUSS_UT)
            return [DecodedSample(f"{source}/imu{msg.id}", msg.time_usec * 1e-6,
                                  (msg.xacc, msg.yacc, msg.zacc),
                                  (msg.xgyro, msg.ygyro, msg.zgyro), mag)]
        ints = (msg.xacc, msg.yacc, msg.zacc, msg.xgyro, msg.ygyro, msg.zgyro)
        flags = _SATURATED if any(v in _INT16 for v in ints) else 0
        has_mag = msg.xmag or msg.ymag or msg.zmag  # all zero: the device has none
        if name in _SCALED:
            sa, sg = G0 * 1e-3, 1e-3
            mag = (msg.xmag * 0.1, msg.ymag * 0.1, msg.zmag * 0.1) if has_mag else None
            return [DecodedSample(f"{source}/imu{_SCALED.index(name)}", msg.time_boot_ms * 1e-3,
                                  (msg.xacc * sa, msg.yacc * sa, msg.zacc * sa),
                                  (msg.xgyro * sg, msg.ygyro * sg, msg.zgyro * sg), mag, flags)]
        sa, sg, sm = self.raw_scales
        if sa is None or sg is None:
            raise FrameError("raw_imu_unscaled", "RAW_IMU packets need the raw_accel_scale "
                             "and raw_gyro_scale parameters (physical units per count)")
        mag = (msg.xmag * sm, msg.ymag * sm, msg.zmag * sm) if sm is not None and has_mag else None
        return [DecodedSample(f"{source}/imu{msg.id}", msg.time_usec * 1e-6,
                              (msg.xacc * sa, msg.yacc * sa, msg.zacc * sa),
                              (msg.xgyro * sg, msg.ygyro * sg, msg.zgyro * sg), mag, flags)]
