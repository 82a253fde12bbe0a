"""Parameters of the ``foot_imu`` sensor, in groups: units, screening, frames."""
from __future__ import annotations

from typing import ClassVar, Literal

from pydantic import field_validator

from firenav_framework.codecs.imu_sample import ImuSample
from firenav_framework.codecs.selection import CodecSelection
from firenav_framework.contract import Params, param
from firenav_framework.formats.imu_csv import UNIT_SCALES

from .calibration import axes_matrix
from .screening import ScreeningLimits

__all__ = ["FootImuParams", "Units", "Frames"]


class Units(Params):
    """Units of ImuBlock inputs (text lines: the line codec's options; CAN and MAVLink
    frames carry their own)."""

    accel: Literal["m/s^2", "g"] = param("m/s^2")
    """specific force unit"""
    gyro: Literal["rad/s", "deg/s"] = param("rad/s")
    """angular rate unit"""
    mag: Literal["uT", "gauss", "nT"] = param("uT")
    """magnetic field unit"""

    def scales(self) -> tuple[float, float, float]:
        """SI factors of accel, gyro and mag."""
        return (UNIT_SCALES["accel_unit"][self.accel], UNIT_SCALES["gyro_unit"][self.gyro],
                UNIT_SCALES["mag_unit"][self.mag])


class Frames(CodecSelection):
    """How RawFrames become sample streams: codecs, device routing, clocks, blocks."""

    record: ClassVar[type] = ImuSample

    codecs: dict[str, str] = param(
        {"can": "can_imu", "mavlink": "mavlink_imu", "serial": "imu_lines", "udp": "imu_lines"},
        description="link transport -> codec decoding its frames (docs/formats/codecs.md)")
    agent_map: dict[str, str] = param({})
    """frame device id (shell pattern, e.g. sys1/comp1/imu0 or can0/node*) -> 'agent' or
    'agent/device'; first match wins"""
    default_agent: str = param("ff1", min_length=1)
    """agent of frame devices that neither agent_map nor the frame's source names"""
    block_s: float = param(0.1, unit="s", gt=0, le=10)
    """frames of one link device are collected this long (frame time) and decoded together into one
    block"""
    clock_resync: float = param(1.0, unit="s", gt=0)
    """a device clock step back (or leap ahead of the frame times) larger than this re-anchors it
    to the frame times"""

    @field_validator("agent_map")
    @classmethod
    def _targets(cls, mapping: dict[str, str]) -> dict[str, str]:
        for pattern, target in mapping.items():
            agent, slash, device = target.partition("/")
            if not agent or (slash and not device):
                raise ValueError(f"agent_map '{pattern}': '{target}' must be 'agent' or "
                                 "'agent/device'")
        return mapping


class FootImuParams(Params):
    """Parameters of the ``foot_imu`` sensor."""

    axes: list[str] = param(["x", "y", "z"])
    """device axis (with sign) that becomes FLU x, y, z (toe, left, up); [x, -y, -z] for z-down FRD
    devices (MAVLink, the real datasets); must be a rotation"""
    units: Units = param(Units())
    """units of ImuBlock inputs"""
    calibration: str | None = param(None)
    """per-device calibration YAML (docs/formats/calibration.md), relative to the pipeline file"""
    screening: ScreeningLimits = param(ScreeningLimits())
    """what is dropped and what is flagged (plausible ranges, full scale, gaps)"""
    frames: Frames = param(Frames())
    """RawFrame inputs: codecs per transport, device ids to agents, device clocks, block length"""
    report_interval: float = param(10.0, unit="s", ge=0)
    """at most one diagnostic per device and problem per this much data time; counts in between are
    summed"""

    @field_validator("axes")
    @classmethod
    def _rotation(cls, axes: list[str]) -> list[str]:
        axes_matrix(axes)
        return axes
