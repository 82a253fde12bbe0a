"""Foot-IMU frame codecs: the shared vocabulary, and the serial/UDP text-line codec.

A *codec* turns sample arrays into link frames (for the simulator and the field kit
to play data onto a bus, and for round-trip tests) and frames back into samples:

=============  =============================================  ==========================
transport      encoder                                        decoder
=============  =============================================  ==========================
``can``        :func:`imu_can.encode_can_imu`                 :class:`imu_can.CanImuDecoder`
``mavlink``    :func:`imu_mavlink.encode_mavlink_imu`         :class:`imu_mavlink.MavlinkImuDecoder`
``serial``     :func:`encode_imu_lines` (also ``udp``)        :class:`LineImuDecoder`
=============  =============================================  ==========================

(modules of ``firenav_plugins.sensors``). Encoders return :class:`EncodedFrame`
tuples; :func:`to_raw_frames` wraps them as :class:`RawFrame` messages following the
conventions of ``docs/DEVELOPING.md``. Decoders return :class:`DecodedSample`
tuples (SI units, the device's own axes, the device's clock), ``None`` for a frame
that is not an IMU frame of theirs, and raise :class:`FrameError` for a frame that
should have been one but cannot be decoded.

Device ids of decoded samples (what ``agent_map`` and calibration files match):
CAN ``<bus>/node<n>`` (bus = the frame's ``device``), MAVLink
``sys<sysid>/comp<compid>/imu<i>``, text lines the frame's ``device`` (port name).
"""
from __future__ import annotations

import math
from collections.abc import Iterable
from typing import NamedTuple

import numpy as np

from firenav_framework.messages import RawFrame

__all__ = ["FrameError", "DecodedSample", "EncodedFrame", "to_raw_frames", "DeviceClock",
           "encode_imu_lines", "LineImuDecoder"]


class FrameError(ValueError):
    """A frame that cannot be decoded. ``code`` is the name it is counted under."""

    def __init__(self, code: str, text: str):
        super().__init__(text)
        self.code = code


class DecodedSample(NamedTuple):
    """One IMU sample decoded from frames (device axes, SI units, device clock)."""

    device: str                                   # raw device id (see module docstring)
    t: float                                      # device time [s]
    accel: tuple[float, float, float]             # specific force [m/s^2]
    gyro: tuple[float, float, float]              # angular rate [rad/s]
    mag: tuple[float, float, float] | None = None  # magnetic field [uT]
    flags: int = 0                                # IMU_FLAG_BITS known from the frame


class EncodedFrame(NamedTuple):
    """One encoded frame: time [s], channel (CAN id, MAVLink msgid or ""), payload."""

    t: float
    channel: int | str
    data: bytes


def to_raw_frames(frames: Iterable[EncodedFrame], *, transport: str, device: str,
                  t_recv: float | None = None) -> list[RawFrame]:
    """Wrap encoded frames as :class:`RawFrame` messages (``t_recv`` = ``t_recv + t``)."""
    return [RawFrame(t=f.t, device=device, transport=transport, channel=f.channel,
                     data=bytes(f.data), t_recv=None if t_recv is None else t_recv + f.t)
            for f in frames]


class DeviceClock:
    """Maps one device's sample clock onto the pipeline clock.

    Device timestamps are regular where frame times (often receive times) jitter, so
    samples keep their device time, shifted by an offset fixed at the first sample
    (``frame.t - t_device``). The offset is re-anchored when the device clock
    steps back by more than ``resync`` seconds (a reboot, a counter wrap; a re-sent
    burst of frames steps back less and is left to the duplicate screening) or leaps
    forward by more than ``resync`` beyond the frame time's own step; a link that
    stalls and then delivers a backlog does not trigger it. A re-anchored sample takes
    the frame time, but never less than one sample interval after the device's last
    pipeline time: the device's time must not step back (its later samples would be
    dropped as time going backwards) when the first frame arrived late.
    """

    def __init__(self, resync: float):
        self.resync = resync
        self.offset: float | None = None
        self._last: tuple[float, float] | None = None  # (device t, frame t)
        self._interval = 0.0                            # last positive device time step

    def to_pipeline(self, t_device: float, t_frame: float) -> tuple[float, bool]:
        """(pipeline time of the sample, whether the offset was re-anchored).

        A non-finite device time is passed through (the screening drops it).
        """
        if not math.isfinite(t_device) or not math.isfinite(t_frame):
            return t_device + (self.offset or 0.0), False
        resynced = False
        if self._last is not None:
            d_dev = t_device - self._last[0]
            if d_dev < -self.resync or d_dev - (t_frame - self._last[1]) > self.resync:
                last_pipeline = self._last[0] + self.offset
                self.offset = max(t_frame, last_pipeline + self._interval) - t_device
                resynced = True
            elif d_dev > 0:
                self._interval = d_dev
        if self.offset is None:
            self.offset = t_frame - t_device
        self._last = (t_device, t_frame)
        return t_device + self.offset, resynced


def encode_imu_lines(time: np.ndarray, accel: np.ndarray, gyro: np.ndarray,
                     mag: np.ndarray | None = None) -> list[EncodedFrame]:
    """Samples as text lines ``t,ax,ay,az,gx,gy,gz[,mx,my,mz]`` (the IMU CSV row order).

    Values are written as given (the decoder's units decide their meaning) with
    shortest round-trip precision; no line ending is included.
    """
    parts = [np.asarray(time, float)[:, None], accel, gyro] + ([mag] if mag is not None else [])
    rows = np.hstack(parts).tolist()
    return [EncodedFrame(r[0], "", ",".join(map(repr, r)).encode("ascii")) for r in rows]


class LineImuDecoder:
    """Decoder of text lines ``t,ax,ay,az,gx,gy,gz[,mx,my,mz]`` (serial or UDP).

    ``accel_scale``, ``gyro_scale``, ``mag_scale`` convert the line's units to SI.
    Blank lines, ``#`` comments and a ``t,ax,...`` header are not IMU frames (None).
    """

    def __init__(self, accel_scale: float = 1.0, gyro_scale: float = 1.0,
                 mag_scale: float = 1.0):
        self.scales = (accel_scale, gyro_scale, mag_scale)

    def decode(self, frame: RawFrame) -> list[DecodedSample] | None:
        try:
            text = bytes(frame.data).decode("ascii").strip()
        except UnicodeDecodeError:
            raise FrameError("bad_frames", "text line with non-ASCII bytes") from None
        fields = text.split(",")
        if not text or text.startswith("#") or fields[0].strip() == "t":
            return None
        if len(fields) not in (7, 10):
            raise FrameError("bad_frames", f"text line has {len(fields)} fields, expected "
                             "7 (t,ax,ay,az,gx,gy,gz) or 10 (with mx,my,mz)")
        try:
            v = [float(f) for f in fields]
        except ValueError:
            raise FrameError("bad_frames", f"text line is not numeric: {text[:60]!r}") from None
        sa, sg, sm = self.scales
        mag = (v[7] * sm, v[8] * sm, v[9] * sm) if len(v) == 10 else None
        return [DecodedSample(frame.device or frame.transport, v[0],
                              (v[1] * sa, v[2] * sa, v[3] * sa),
                              (v[4] * sg, v[5] * sg, v[6] * sg), mag)]
