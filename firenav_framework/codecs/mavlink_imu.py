"""``mavlink_imu``: MAVLink IMU messages, HIGHRES_IMU, SCALED_IMU(2, 3) and RAW_IMU.

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
report specific force (about -9.81 m/s^2 on z at rest): a device that follows it is
mapped to FLU with the sensor's ``axes: [x, -y, -z]``. int16 values at either end of
their range are flagged saturated; an all-zero magnetometer field means the device has
none. Addresses (and record devices) are ``sys<sysid>/comp<compid>/imu<index>``.
"""
from __future__ import annotations

import functools
import re
from collections.abc import Sequence
from typing import Any, Literal

import numpy as np

from ..contract.params import Params, param
from ..messages import IMU_FLAG_BITS, ImuBlock, RawFrame
from .base import Codec, Decoded, EncodedFrame, FrameError
from .imu_sample import ImuSample, ImuSamples, check_device_times
from .mavlink_payloads import HIGHRES_ID, PACKET_PROBLEMS, unpack_highres

__all__ = ["MavlinkImuCodec", "MAVLINK_IMU_IDS", "G0"]

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
_ADDRESS = re.compile(r"sys(\d+)/comp(\d+)/imu(\d+)")

Message = Literal["HIGHRES_IMU", "SCALED_IMU", "RAW_IMU"]


@functools.lru_cache(maxsize=1)
def _dialect() -> Any:
    from pymavlink.dialects.v20 import common

    return common


def _int16(v: np.ndarray) -> np.ndarray:
    return np.clip(np.round(v), *_INT16).astype(np.int64)


class MavlinkImuCodec(Codec):
    """MAVLink IMU packets: HIGHRES_IMU, SCALED_IMU(2, 3) and RAW_IMU, MAVLink 1 or 2.

    Decoding reads the messages listed in ``messages`` (list only one for a device that
    sends the same IMU as several: they would be merged into one sample stream); other
    message ids are not IMU frames (``None``). RAW_IMU needs ``raw_accel_scale`` and
    ``raw_gyro_scale``: without them its packets raise :class:`FrameError`
    ``raw_imu_unscaled``. Encoding sends ``send`` as complete MAVLink 2 packets (the
    link's ``RawFrame.data``), int16 fields rounded and clipped to their range, the
    packet sequence continuing per address across calls.
    """

    name = "mavlink_imu"
    transport = "mavlink"
    record = ImuSample

    class Options(Codec.Options):
        messages: list[Message] = param(["HIGHRES_IMU", "SCALED_IMU", "RAW_IMU"], min_length=1)
        """MAVLink messages decoded (SCALED_IMU includes SCALED_IMU2 and 3); list one if a device
        sends the same IMU as several"""
        send: Message = param("HIGHRES_IMU")
        """the message encoding sends"""
        raw_accel_scale: float | None = param(None, unit="m/s^2", gt=0)
        """RAW_IMU accel units per count"""
        raw_gyro_scale: float | None = param(None, unit="rad/s", gt=0)
        """RAW_IMU gyro units per count"""
        raw_mag_scale: float | None = param(None, unit="uT", gt=0)
        """RAW_IMU magnetometer units per count"""

    def __init__(self, options: Params | dict[str, Any] | None = None, **kw: Any):
        super().__init__(options, **kw)
        messages = self.options.messages
        names = set(messages) | (set(_SCALED) if "SCALED_IMU" in messages else set())
        self.ids = {MAVLINK_IMU_IDS[n] for n in names}
        self._parser = _dialect().MAVLink(None)
        self._senders: dict[tuple[int, int, int], Any] = {}  # address -> MAVLink packer
        self._device_names: dict[int, str] = {}  # sysid << 16 | compid << 8 | id -> name

    def channels(self, address: str) -> Sequence[int]:
        send = self.options.send
        return [MAVLINK_IMU_IDS[_SCALED[self._address(address)[2]] if send == "SCALED_IMU"
                                else send]]

    @staticmethod
    def _address(address: str) -> tuple[int, int, int]:
        """(sysid, compid, imu index) of ``address`` (``""``: sys1/comp1/imu0)."""
        if not address:
            return 1, 1, 0
        m = _ADDRESS.fullmatch(address)
        if m is None:
            raise ValueError(f"MAVLink IMU address {address!r} is not sys<s>/comp<c>/imu<i>")
        sysid, compid, imu = map(int, m.groups())
        if not (1 <= sysid <= 255 and 0 <= compid <= 255 and 0 <= imu <= 255):
            raise ValueError(f"MAVLink IMU address {address!r}: system 1-255, component "
                             "and IMU index 0-255")
        return sysid, compid, imu

    # -- decoding ----------------------------------------------------------------------
    def decode(self, frame: RawFrame) -> list[ImuSample] | None:
        if frame.channel not in self.ids:
            return None
        if frame.channel == HIGHRES_ID:
            records, _, problems, _ = self.decode_batch([frame])
            if problems:
                raise problems[0][1]
            return list(records)
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
            return [ImuSample(f"{source}/imu{msg.id}", msg.time_usec * 1e-6,
                              (msg.xacc, msg.yacc, msg.zacc),
                              (msg.xgyro, msg.ygyro, msg.zgyro), mag)]
        ints = (msg.xacc, msg.yacc, msg.zacc, msg.xgyro, msg.ygyro, msg.zgyro)
        flags = _SATURATED if any(v in _INT16 for v in ints) else 0
        has_mag = msg.xmag or msg.ymag or msg.zmag  # all zero: the device has none
        if name in _SCALED:
            sa, sg = G0 * 1e-3, 1e-3
            mag = (msg.xmag * 0.1, msg.ymag * 0.1, msg.zmag * 0.1) if has_mag else None
            return [ImuSample(f"{source}/imu{_SCALED.index(name)}", msg.time_boot_ms * 1e-3,
                              (msg.xacc * sa, msg.yacc * sa, msg.zacc * sa),
                              (msg.xgyro * sg, msg.ygyro * sg, msg.zgyro * sg), mag, flags)]
        o = self.options
        sa, sg, sm = o.raw_accel_scale, o.raw_gyro_scale, o.raw_mag_scale
        if sa is None or sg is None:
            raise FrameError("raw_imu_unscaled", "RAW_IMU packets need the raw_accel_scale "
                             "and raw_gyro_scale options (physical units per count)")
        mag = (msg.xmag * sm, msg.ymag * sm, msg.zmag * sm) if sm is not None and has_mag else None
        return [ImuSample(f"{source}/imu{msg.id}", msg.time_usec * 1e-6,
                          (msg.xacc * sa, msg.yacc * sa, msg.zacc * sa),
                          (msg.xgyro * sg, msg.ygyro * sg, msg.zgyro * sg), mag, flags)]

    def decode_batch(self, frames: Sequence[RawFrame]) -> Decoded:
        """HIGHRES_IMU packets checked and read many at once with numpy (the same
        records and problems as :meth:`decode`); the other IMU messages frame by frame."""
        highres: list[int] = []
        others: list[int] = []
        ignored = 0
        for i, frame in enumerate(frames):
            if frame.channel == HIGHRES_ID and HIGHRES_ID in self.ids:
                highres.append(i)
            elif frame.channel in self.ids:
                others.append(i)
            else:
                ignored += 1
        problems: list[tuple[int, FrameError]] = []
        parts = []
        if highres:
            parts.append(self._highres([frames[i] for i in highres], highres, problems))
        if others:
            rest = super().decode_batch([frames[i] for i in others])
            problems += [(others[i], exc) for i, exc in rest.problems]
            problems.sort(key=lambda p: p[0])
            parts.append((np.array([others[i] for i in rest.origin], np.int64),
                          ImuSamples.from_records(rest.records)))
        records, origin = ImuSamples.merge(parts)
        return Decoded(records, origin, problems, ignored)

    def _highres(self, frames: list[RawFrame], index: list[int],
                 problems: list[tuple[int, FrameError]]) -> tuple[np.ndarray, ImuSamples]:
        rows = unpack_highres([f.data for f in frames])
        status = rows[:, 13]
        if status.any():
            for k in np.flatnonzero(status).tolist():
                problems.append((index[k], FrameError("bad_frames", f"MAVLink msgid "
                                f"{HIGHRES_ID}: {PACKET_PROBLEMS[int(status[k])]}")))
            good = status == 0
            rows, index = rows[good], np.asarray(index)[good]
        names = self._device_names
        device = [names.get(k) or names.setdefault(k, f"sys{k >> 16}/comp{(k >> 8) & 0xFF}"
                                                      f"/imu{k & 0xFF}")
                  for k in rows[:, 11].astype(np.int64).tolist()]
        mag = None
        has_mag = rows[:, 10].astype(np.int64) & _HIGHRES_MAG == _HIGHRES_MAG
        if has_mag.any():
            mag = rows[:, 7:10] * GAUSS_UT
            mag[~has_mag] = np.nan
        batch = ImuSamples(device, rows[:, 0], rows[:, 1:4], rows[:, 4:7], mag,
                           np.zeros(len(rows), np.uint8))
        return np.asarray(index), batch

    # -- encoding ----------------------------------------------------------------------
    def encode(self, block: ImuBlock, *, address: str = "") -> list[EncodedFrame]:
        """The ``send`` packets of every sample of ``block`` (device axes, FRD for
        MAVLink; SI; ``time`` the device clock [s] >= 0; ``mag`` [uT] or None), sent as
        ``address``. SCALED_IMU addresses ``imu0``-``imu2`` select SCALED_IMU/2/3."""
        sysid, compid, imu = self._address(address)
        o = self.options
        message = o.send
        time = check_device_times(block, "MAVLink IMU")
        accel, gyro, mag = block.accel, block.gyro, block.mag
        n = len(time)
        mag_arr = np.zeros((n, 3)) if mag is None else np.asarray(mag, float)
        mav_mod = _dialect()
        if message == "HIGHRES_IMU":
            updated = _HIGHRES_ACCEL_GYRO | (0 if mag is None else _HIGHRES_MAG)
            usec = np.round(time * 1e6).astype(np.int64).tolist()
            rows = np.hstack((accel, gyro, mag_arr / GAUSS_UT)).tolist()
            msgs = [mav_mod.MAVLink_highres_imu_message(u, *r, 0.0, 0.0, 0.0, 0.0, updated, imu)
                    for u, r in zip(usec, rows)]
        elif message == "SCALED_IMU":
            if imu > 2:
                raise ValueError("SCALED_IMU carries IMUs 0..2 (SCALED_IMU, SCALED_IMU2, "
                                 "SCALED_IMU3)")
            cls = getattr(mav_mod, f"MAVLink_{_SCALED[imu].lower()}_message")
            ms = (np.round(time * 1e3).astype(np.int64) % (1 << 32)).tolist()
            ints = _int16(np.hstack((accel / G0 * 1e3, gyro * 1e3, mag_arr * 10.0))).tolist()
            msgs = [cls(m, *r, 0) for m, r in zip(ms, ints)]
        else:
            if o.raw_accel_scale is None or o.raw_gyro_scale is None or (
                    mag is not None and o.raw_mag_scale is None):
                raise ValueError("RAW_IMU needs raw_accel_scale and raw_gyro_scale (and "
                                 "raw_mag_scale with mag)")
            usec = np.round(time * 1e6).astype(np.int64).tolist()
            ints = _int16(np.hstack((accel / o.raw_accel_scale, gyro / o.raw_gyro_scale,
                                     mag_arr / (o.raw_mag_scale or 1.0)))).tolist()
            msgs = [mav_mod.MAVLink_raw_imu_message(u, *r, imu, 0) for u, r in zip(usec, ints)]
        sender = self._senders.get((sysid, compid, imu))
        if sender is None:
            sender = self._senders[(sysid, compid, imu)] = mav_mod.MAVLink(
                None, srcSystem=sysid, srcComponent=compid)
        msgid = self.channels(address)[0]
        frames = []
        for t, m in zip(time.tolist(), msgs):
            frames.append(EncodedFrame(t, msgid, bytes(m.pack(sender))))
            sender.seq = (sender.seq + 1) % 256   # pack() uses it, only send() advances it
        return frames
