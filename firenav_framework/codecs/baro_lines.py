"""``baro_lines``: a barometer's text lines, one static-pressure reading each::

    BARO,<device>,<pressure_pa>[,<temperature_c>][*HH]

``device`` is the barometer's id: ``<agent>/<device>`` for one a firefighter wears
(``ff1/baro``), any other name for the reference at the entrance or base station
(``base/baro``). ``pressure_pa`` is the static pressure [Pa], ``temperature_c`` the
sensor's temperature [degrees Celsius, as datasheets and the line give it] when it
reports one. ``*HH`` is optional: the XOR of the bytes before ``*`` in hex, as NMEA
(:mod:`.checked_lines`). The reading's time is the frame's (the receive clock).
"""
from __future__ import annotations

import math
from typing import NamedTuple

from .base import FrameError
from .checked_lines import NAME, CheckedLinesCodec

__all__ = ["BaroReading", "BaroLinesCodec", "PRESSURE_RANGE_PA", "ZERO_CELSIUS_K"]

#: Pressures a barometer can read on Earth's surface and in buildings [Pa] (a line
#: outside this range is a broken one: the Dead Sea is about 107 kPa, 5000 m 54 kPa).
PRESSURE_RANGE_PA = (30_000.0, 120_000.0)
ZERO_CELSIUS_K = 273.15


class BaroReading(NamedTuple):
    """One barometer line: ``t`` [s] the frame's time, ``device`` the barometer's id,
    ``pressure`` [Pa], ``temperature`` [K] (None: not reported)."""

    t: float
    device: str
    pressure: float
    temperature: float | None = None


class BaroLinesCodec(CheckedLinesCodec):
    """Barometer lines: BARO,<device>,<pressure Pa>[,<temperature C>] with an optional *HH checksum.

    Other lines on the link are not ours (None); a broken BARO line raises
    :class:`FrameError` (``checksum_errors`` for a wrong checksum, else ``bad_frames``).
    """

    name = "baro_lines"
    record = BaroReading
    field_counts = {"BARO": (3, 4)}

    def parse(self, t: float, parts: list[str], text: str) -> BaroReading:
        device = parts[1]
        if not NAME.match(device):
            raise FrameError("bad_frames", f"bad barometer id: {text!r}")
        try:
            pressure = float(parts[2])
            celsius = float(parts[3]) if len(parts) == 4 and parts[3] else None
        except ValueError:
            raise FrameError("bad_frames", f"non-numeric field: {text!r}") from None
        lo, hi = PRESSURE_RANGE_PA
        if not (math.isfinite(pressure) and lo <= pressure <= hi):
            raise FrameError("bad_frames", f"pressure outside {lo:.0f}..{hi:.0f} Pa: {text!r}")
        if celsius is not None and not (math.isfinite(celsius) and -60.0 <= celsius <= 300.0):
            raise FrameError("bad_frames", f"temperature out of range: {text!r}")
        kelvin = None if celsius is None else celsius + ZERO_CELSIUS_K
        return BaroReading(t, device, pressure, kelvin)

    def line_fields(self, r: BaroReading) -> list[str]:
        """The line of a reading (no terminator), pressure to 0.01 Pa."""
        fields = ["BARO", r.device, f"{r.pressure:.2f}"]
        if r.temperature is not None:
            fields.append(f"{r.temperature - ZERO_CELSIUS_K:.2f}")
        return fields
