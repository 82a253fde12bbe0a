"""IMU axis mapping and per-device calibration files (``docs/formats/calibration.md``).

A device's samples are corrected in its own axes, then rotated to FLU::

    v_cal = M @ (s * (v_raw - b))        bias b, scale s (per axis), misalignment M
    v_flu = R @ v_cal                     R from the ``axes`` parameter

for the accelerometer [m/s^2], gyroscope [rad/s] and magnetometer [uT] separately
(for the magnetometer b is the hard-iron offset and ``M @ diag(s)`` the soft-iron
matrix). :class:`LinearCorrection` holds the combined ``(R @ M @ diag(s), b)``.
"""
from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from pydantic import BaseModel, ConfigDict, ValidationError, field_validator, model_validator

from firenav_framework.pipeline import pydantic_message
from firenav_framework.yaml_locations import ConfigError, load

__all__ = ["axes_matrix", "SensorCalibration", "DeviceCalibration", "CalibrationFile",
           "load_calibration", "LinearCorrection"]

_AXIS = re.compile(r"^([+-]?)([xyz])$")

Vec3 = tuple[float, float, float]


def axes_matrix(axes: Sequence[str]) -> np.ndarray:
    """The rotation R with ``v_flu = R @ v_device`` for an ``axes`` list.

    ``axes[i]`` names the device axis, with its sign, that becomes FLU axis i (x toe,
    y left, z up): a z-down device whose x points to the toe (FRD, as MAVLink) is
    ``["x", "-y", "-z"]``. Raises ``ValueError`` unless the entries name each axis
    once and form a proper rotation (det +1): a mirror image cannot be undone by
    mounting, so it is always a typo.
    """
    if isinstance(axes, str) or len(axes) != 3:
        raise ValueError(f"axes must list three entries like [x, -y, -z], got {axes!r}")
    R = np.zeros((3, 3))
    used = []
    for i, entry in enumerate(axes):
        m = _AXIS.match(str(entry).strip().lower())
        if m is None:
            raise ValueError(f"axes entry {entry!r} must be x, y or z with an optional sign")
        used.append(m.group(2))
        R[i, "xyz".index(m.group(2))] = -1.0 if m.group(1) == "-" else 1.0
    if len(set(used)) != 3:
        raise ValueError(f"axes {list(axes)} must use each of x, y, z once")
    if np.linalg.det(R) < 0:
        raise ValueError(f"axes {list(axes)} is a reflection (det -1), not a rotation: "
                         "flip the sign of one entry (a z-down FRD device is [x, -y, -z])")
    return R


class SensorCalibration(BaseModel):
    """Bias, per-axis scale and misalignment of one sensor (device axes, SI units)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    bias: Vec3 = (0.0, 0.0, 0.0)
    scale: Vec3 = (1.0, 1.0, 1.0)
    misalignment: tuple[Vec3, Vec3, Vec3] = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))

    @field_validator("bias", "scale", "misalignment")
    @classmethod
    def _finite(cls, v):
        if not np.all(np.isfinite(np.asarray(v, float))):
            raise ValueError("values must be finite numbers")
        return v

    @field_validator("scale")
    @classmethod
    def _positive(cls, v: Vec3) -> Vec3:
        if min(v) <= 0:
            raise ValueError(f"scale factors must be positive, got {list(v)}")
        return v

    @model_validator(mode="after")
    def _conditioned(self) -> "SensorCalibration":
        m = np.asarray(self.misalignment, float)
        off = m - np.diag(np.diag(m))
        if np.any(np.diag(m) < 0.5) or np.any(np.diag(m) > 2) or np.any(np.abs(off) > 0.5):
            raise ValueError(f"misalignment {m.tolist()} is far from the identity (diagonal "
                             "must be 0.5..2, off-diagonal under 0.5): axis order and signs "
                             "belong in the sensor's `axes` parameter, not here")
        return self


class DeviceCalibration(BaseModel):
    """Calibration of one device's accelerometer, gyroscope and magnetometer."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    accel: SensorCalibration = SensorCalibration()
    gyro: SensorCalibration = SensorCalibration()
    mag: SensorCalibration = SensorCalibration()


class CalibrationFile(BaseModel):
    """A calibration file: ``devices`` by device id, and an optional ``default``."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    version: int = 1
    default: DeviceCalibration | None = None
    devices: dict[str, DeviceCalibration] = {}

    @field_validator("version")
    @classmethod
    def _version(cls, v: int) -> int:
        if v != 1:
            raise ValueError(f"unsupported calibration file version {v}; this firenav reads 1")
        return v

    def for_device(self, *ids: str) -> DeviceCalibration | None:
        """The entry of the first of ``ids`` listed, else ``default`` (None if neither)."""
        for device_id in ids:
            if device_id in self.devices:
                return self.devices[device_id]
        return self.default


def load_calibration(path: str | Path) -> CalibrationFile:
    """Read and check a calibration YAML file; problems come with file:line:col."""
    doc = load(path)
    try:
        return CalibrationFile.model_validate(doc.data if doc.data is not None else {})
    except ValidationError as exc:
        raise ConfigError([doc.problem(tuple(err["loc"]), pydantic_message(err))
                           for err in exc.errors()]) from None


@dataclass(frozen=True)
class LinearCorrection:
    """``v_out = A @ (v - b)`` for (N, 3) arrays: calibration and axis mapping in one."""

    A: np.ndarray
    b: np.ndarray

    @classmethod
    def build(cls, R: np.ndarray, cal: SensorCalibration | None) -> "LinearCorrection":
        if cal is None:
            return cls(A=R, b=np.zeros(3))
        M = np.asarray(cal.misalignment, float)
        return cls(A=R @ M @ np.diag(cal.scale), b=np.asarray(cal.bias, float))

    def __call__(self, v: np.ndarray) -> np.ndarray:
        return (v - self.b) @ self.A.T
