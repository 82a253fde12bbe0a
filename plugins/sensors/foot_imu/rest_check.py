"""Set-up checks on a device's first conditioned data: units and axes, judged at rest.

A wrong ``axes`` entry or unit is the most common set-up mistake, and gravity shows it:
at rest the specific force is about 9.81 m/s^2 and points up (+z in FLU).
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from firenav_framework.messages import ImuBlock

from .calibration import axes_matrix

__all__ = ["RestCheck", "GRAVITY", "upright_axes"]

GRAVITY = 9.81           # m/s^2
_UNITS_AFTER_S = 0.5     # the units check looks at this much data
_GIVE_UP_S = 10.0        # both checks give up after this much data
_STILL_SAMPLES = 20      # samples at rest the axes check needs


#: Rotations of the FLU frame that bring gravity's reaction from the FLU axis (index,
#: sign) it was measured on to +z (180 deg about x; 90 deg about y or x).
_TO_UP = {(2, -1): np.diag([1.0, -1.0, -1.0]),
          (0, 1): np.array([[0.0, 0, -1], [0, 1, 0], [1, 0, 0]]),
          (0, -1): np.array([[0.0, 0, 1], [0, 1, 0], [-1, 0, 0]]),
          (1, 1): np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]]),
          (1, -1): np.array([[1.0, 0, 0], [0, 0, 1], [0, -1, 0]])}


def upright_axes(axes: Sequence[str], up_flu: np.ndarray) -> list[str] | None:
    """The ``axes`` entry that turns the axis reading most of gravity's reaction
    (``up_flu``, FLU components of the specific force at rest under the declared
    ``axes``) into +z; None when that is +z already."""
    j = int(np.argmax(np.abs(up_flu)))
    sign = 1 if up_flu[j] > 0 else -1
    if (j, sign) == (2, 1):
        return None
    m = _TO_UP[(j, sign)] @ axes_matrix(axes)
    return [("-" if m[i, k] < 0 else "") + "xyz"[k]
            for i in range(3) for k in range(3) if m[i, k] != 0]


class RestCheck:
    """Once per device: does the specific force read 9.81 m/s^2, and +z at rest?

    :meth:`feed` takes the device's conditioned (FLU, SI) blocks until both checks are
    done and returns what it found as ``(code, text)`` diagnostics. ``axes`` is the
    sensor's declared mapping, so that the axes check can say which one reads gravity.
    """

    def __init__(self, device: str, axes: Sequence[str] = ("x", "y", "z")):
        self.device = device
        self.axes = list(axes)
        self.units_checked = False
        self.axes_checked = False
        self._first_t: float | None = None
        self._window: list[np.ndarray] = []   # (n, 6) FLU accel + gyro

    @property
    def done(self) -> bool:
        return self.units_checked and self.axes_checked

    def feed(self, block: ImuBlock) -> list[tuple[str, str]]:
        """The problems ``block`` (with the blocks before it) reveals."""
        found = []
        if self._first_t is None:
            self._first_t = float(block.time[0])
        self._window.append(np.hstack((block.accel, block.gyro)))
        data = np.concatenate(self._window)
        span = float(block.t) - self._first_t
        norm = np.linalg.norm(data[:, :3], axis=1)
        if not self.units_checked and span >= _UNITS_AFTER_S:
            self.units_checked = True
            med = float(np.median(norm))
            unit = "g" if 0.5 < med < 2.0 else "m/s^2" if 50.0 < med < 200.0 else None
            if unit:
                found.append(("imu_units_check",
                              f"{self.device}: median specific force is {med:.2f} in the "
                              "configured units (gravity should read 9.81 m/s^2): is the "
                              f"device's accel unit {unit}? (`units: {{accel: {unit}}}`, "
                              "or the text-line codec's accel_unit)"))
        still = (np.abs(norm - GRAVITY) < 0.5) & (np.linalg.norm(data[:, 3:], axis=1) < 0.3)
        if not self.axes_checked and still.sum() >= _STILL_SAMPLES:
            self.axes_checked = True
            up = data[still, :3].mean(axis=0)
            if up[2] < 0.5 * GRAVITY:
                better = upright_axes(self.axes, up)
                fix = (f"set `axes: [{', '.join(better)}]`" if better is not None
                       else "check `axes`")
                found.append(("imu_axes_check",
                              f"{self.device}: at rest gravity reads {up[2]:+.2f} m/s^2 on "
                              f"FLU z (x {up[0]:+.2f}, y {up[1]:+.2f}; expected about "
                              f"+9.81 on z) with `axes: [{', '.join(self.axes)}]`: {fix} "
                              "(a z-down device is [x, -y, -z]), unless the foot rested "
                              "upside down (crawling)"))
        if span >= _GIVE_UP_S:
            self.units_checked = self.axes_checked = True
        if self.done:
            self._window = []
        return found
