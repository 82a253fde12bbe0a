"""``uwb_lines``: UWB ranging reports as checked text lines (``docs/formats/uwb.md``)::

    RANGE,<tag>,<anchor>,<range_mm>,<rx_power_dbm>,<fp_power_dbm>[,<seq>][*<HH>]
"""
from __future__ import annotations

import math

from .base import FrameError
from .checked_lines import NAME, CheckedLinesCodec
from .twr_report import TwrReport

__all__ = ["UwbLinesCodec"]


def _power(v: float | None) -> str:
    return "" if v is None else f"{v:.1f}"


class UwbLinesCodec(CheckedLinesCodec):
    """UWB two-way-ranging reports as RANGE text lines with an optional *HH checksum.

    Lines of other kinds are not ours (None); a broken RANGE line raises
    :class:`FrameError` (``checksum_errors`` for a wrong checksum, else ``bad_frames``).
    An empty or ``-1`` range is a failed exchange (``range_m`` None).
    """

    name = "uwb_lines"
    record = TwrReport
    field_counts = {"RANGE": (6, 7)}

    def parse(self, t: float, parts: list[str], text: str) -> TwrReport:
        _, tag, anchor, mm, rx, fp, *rest = parts
        if not (NAME.match(tag) and NAME.match(anchor)):
            raise FrameError("bad_frames", f"UWB line has a bad tag or anchor id: {text!r}")
        try:
            rng = None if mm in ("", "-1") else int(mm) / 1000.0
            rxv = float(rx) if rx else None
            fpv = float(fp) if fp else None
            seq = int(rest[0]) if rest and rest[0] else None
        except ValueError:
            raise FrameError("bad_frames", f"UWB line has a non-numeric field: {text!r}") from None
        if (rng is not None and rng < 0) or (seq is not None and not 0 <= seq <= 255):
            raise FrameError("bad_frames", f"UWB line field out of range: {text!r}")
        for v in (rxv, fpv):
            if v is not None and not math.isfinite(v):
                raise FrameError("bad_frames", f"UWB line power is not finite: {text!r}")
        return TwrReport(t, tag, anchor, rng, rxv, fpv, seq)

    def line_fields(self, r: TwrReport) -> list[str]:
        """The line of a report (no terminator), range in whole millimetres."""
        mm = "" if r.range_m is None else str(int(round(r.range_m * 1000)))
        fields = ["RANGE", str(r.tag), str(r.anchor), mm, _power(r.rx_dbm), _power(r.fp_dbm)]
        if r.seq is not None:
            fields.append(str(r.seq))
        return fields
