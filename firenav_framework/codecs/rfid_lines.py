"""``rfid_lines``: an RFID reader's text lines, tag reads and deployments::

    TAG,<reader>,<tag_id>,<rssi_dbm>[,<reads>][*HH]     a read; rssi may be empty
    DEPLOY,<reader>,<tag_id>[*HH]                       the wearer attached this tag

``*HH`` is optional: the XOR of the bytes before ``*`` in hex, as NMEA
(:mod:`.checked_lines`).
"""
from __future__ import annotations

import math
from typing import Literal, NamedTuple

from .base import FrameError
from .checked_lines import NAME, CheckedLinesCodec

__all__ = ["RfidEvent", "RfidLinesCodec"]


class RfidEvent(NamedTuple):
    """One reader line: ``kind`` "TAG" (a read) or "DEPLOY" (a tag attached).

    ``t`` [s] the frame's time; ``reader`` the reader's id (``<agent>/<device>`` by
    convention); ``rssi_dbm`` the read's signal strength [dBm] (None: not reported);
    ``reads`` how many reads the line stands for (>= 1).
    """

    t: float
    kind: Literal["TAG", "DEPLOY"]
    reader: str
    tag_id: str
    rssi_dbm: float | None = None
    reads: int = 1


class RfidLinesCodec(CheckedLinesCodec):
    """RFID reader lines: TAG reads and DEPLOY events, with an optional *HH checksum.

    Other lines on the link are not ours (None); a broken TAG or DEPLOY line raises
    :class:`FrameError` (``checksum_errors`` for a wrong checksum, else ``bad_frames``).
    """

    name = "rfid_lines"
    record = RfidEvent
    field_counts = {"TAG": (4, 5), "DEPLOY": (3,)}

    def parse(self, t: float, parts: list[str], text: str) -> RfidEvent:
        kind = parts[0]
        reader, tag_id = parts[1], parts[2]
        if not (NAME.match(reader) and NAME.match(tag_id)):
            raise FrameError("bad_frames", f"bad reader or tag id: {text!r}")
        if kind == "DEPLOY":
            return RfidEvent(t, "DEPLOY", reader, tag_id)
        try:
            rssi = float(parts[3]) if parts[3] else None
            reads = int(parts[4]) if len(parts) == 5 else 1
        except ValueError:
            raise FrameError("bad_frames", f"non-numeric field: {text!r}") from None
        if (rssi is not None and not math.isfinite(rssi)) or reads < 1:
            raise FrameError("bad_frames", f"field out of range: {text!r}")
        return RfidEvent(t, "TAG", reader, tag_id, rssi, reads)

    def line_fields(self, e: RfidEvent) -> list[str]:
        """The line of an event (no terminator)."""
        fields = [e.kind, e.reader, e.tag_id]
        if e.kind == "TAG":
            fields.append("" if e.rssi_dbm is None else f"{e.rssi_dbm:.1f}")
            if e.reads != 1:
                fields.append(str(e.reads))
        return fields
