"""``imu_lines``: IMU samples as text lines ``t,ax,ay,az,gx,gy,gz[,mx,my,mz]`` (serial, UDP).

The fields are the IMU CSV row order (``docs/formats/imu-csv.md``), in the units the
options name (the device's own: a line does not say). Records are named after the
frame's ``device`` (the port or the sender's ``host:port``).
"""
from __future__ import annotations

from typing import Any, Literal

import numpy as np

from ..contract.params import Params, param
from ..formats.imu_csv import UNIT_SCALES
from ..messages import ImuBlock, RawFrame
from .base import Codec, EncodedFrame, FrameError
from .imu_sample import ImuSample

__all__ = ["ImuLinesCodec"]


class ImuLinesCodec(Codec):
    """IMU text lines t,ax,ay,az,gx,gy,gz[,mx,my,mz] in the device's units (serial, UDP).

    Blank lines, ``#`` comments and a ``t,ax,...`` header are not IMU frames (None);
    ``nan`` fields are passed on for the sensor's screening. Encoding writes each
    sample in the options' units with shortest round-trip precision, no line ending.
    """

    name = "imu_lines"
    transport = "lines"
    record = ImuSample

    class Options(Codec.Options):
        accel_unit: Literal["m/s^2", "g"] = param("m/s^2")
        """accel units of the lines"""
        gyro_unit: Literal["rad/s", "deg/s"] = param("rad/s")
        """gyro units of the lines"""
        mag_unit: Literal["uT", "gauss", "nT"] = param("uT")
        """magnetometer units of the lines"""

    def __init__(self, options: Params | dict[str, Any] | None = None, **kw: Any):
        super().__init__(options, **kw)
        o = self.options
        self.scales = (UNIT_SCALES["accel_unit"][o.accel_unit],
                       UNIT_SCALES["gyro_unit"][o.gyro_unit],
                       UNIT_SCALES["mag_unit"][o.mag_unit])

    def decode(self, frame: RawFrame) -> list[ImuSample] | None:
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
        return [ImuSample(frame.device or frame.transport, v[0],
                          (v[1] * sa, v[2] * sa, v[3] * sa),
                          (v[4] * sg, v[5] * sg, v[6] * sg), mag)]

    def encode(self, block: ImuBlock, *, address: str = "") -> list[EncodedFrame]:
        """One line per sample of ``block`` (SI, device axes), stamped with its time."""
        sa, sg, sm = self.scales
        parts = [np.asarray(block.time, float)[:, None], block.accel / sa, block.gyro / sg]
        if block.mag is not None:
            parts.append(block.mag / sm)
        rows = np.hstack(parts).tolist()
        return [EncodedFrame(r[0], "", ",".join(map(repr, r)).encode("ascii")) for r in rows]
