"""``uwb_can``: UWB ranging reports as the CAN frame ``UWB_TWR_REPORT`` (``dbc/uwb_twr.dbc``).

The DBC file owns the layout (``docs/formats/uwb.md``): one classic 8-byte frame per
report, tag and anchor numbers 0-255, the range in millimetres (all ones: ranging
failed) and the two powers in 0.5 dB steps (raw 255: not available).
"""
from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np

from ..contract.params import Params
from ..messages import RawFrame
from .base import EncodedFrame, FrameError
from .can_database import DbcCodec, MessageSpec
from .twr_report import TwrReport

__all__ = ["UwbCanCodec"]

_MESSAGE = "UWB_TWR_REPORT"
_NEEDS = (MessageSpec(_MESSAGE, _MESSAGE, ("TagId", "AnchorId", "RangeMm", "RxPower",
                                           "FpPower", "Seq")),)
_RANGE_FAILED_MM = (1 << 24) - 1        # RangeMm value meaning "ranging failed"
_POWER_NA_RAW = 255                      # raw power byte meaning "not available"


class UwbCanCodec(DbcCodec):
    """UWB two-way-ranging reports as one UWB_TWR_REPORT CAN frame each (DBC).

    Frames with other ids (IMU frames on the same bus ...) are not ours (None); a
    report frame of the wrong length raises :class:`FrameError` ``bad_frames``.
    Encoding needs numeric tag and anchor ids (0-255).
    """

    name = "uwb_can"
    transport = "can"
    record = TwrReport
    dbc_shipped = "uwb_twr.dbc"
    dbc_needs = _NEEDS
    dbc_doc = "docs/formats/uwb.md"

    def __init__(self, options: Params | dict[str, Any] | None = None, **kw: Any):
        super().__init__(options, **kw)
        self.message = self.db.get_message_by_name(_MESSAGE)

    def channels(self, address: str) -> Sequence[int]:
        return [self.message.frame_id]

    def decode(self, frame: RawFrame) -> list[TwrReport] | None:
        if not isinstance(frame.channel, int):
            raise FrameError("bad_frames", f"CAN channel {frame.channel!r} is not an id")
        if frame.channel != self.message.frame_id:
            return None
        try:
            sig = self.message.decode(bytes(frame.data), decode_choices=False, scaling=False)
        except Exception as exc:  # cantools DecodeError: wrong length
            raise FrameError("bad_frames", f"CAN id 0x{frame.channel:X}: {exc}") from None

        def power(raw: int) -> float | None:
            return None if raw == _POWER_NA_RAW else raw * 0.5 - 128.0
        mm = int(sig["RangeMm"])
        return [TwrReport(frame.t, str(int(sig["TagId"])), str(int(sig["AnchorId"])),
                          None if mm == _RANGE_FAILED_MM else mm / 1000.0,
                          power(int(sig["RxPower"])), power(int(sig["FpPower"])),
                          int(sig["Seq"]))]

    def encode(self, reports: Iterable[TwrReport], *, address: str = "") -> list[EncodedFrame]:
        """One frame per report; powers clipped to -128..-1 dBm, None sent as n/a."""
        def power(v: float | None) -> float:
            return -0.5 if v is None else float(np.clip(v, -128.0, -1.0))
        out = []
        for r in reports:
            mm = _RANGE_FAILED_MM if r.range_m is None else int(
                min(round(r.range_m * 1000), _RANGE_FAILED_MM - 1))
            data = self.message.encode({"TagId": int(r.tag), "AnchorId": int(r.anchor),
                                        "RangeMm": mm, "RxPower": power(r.rx_dbm),
                                        "FpPower": power(r.fp_dbm), "Seq": (r.seq or 0) & 0xFF})
            out.append(EncodedFrame(r.t, self.message.frame_id, bytes(data)))
        return out
