"""Reader of MAVLink ``.tlog`` files: 8-byte big-endian UNIX microseconds + packet.

Packets are framed by their own header (MAVLink 1 ``0xFE``, MAVLink 2 ``0xFD`` with
its optional 13-byte signature), so the reader is fast; each becomes the RawFrame the
live ``mavlink`` source made of it (the same function,
:func:`~firenav_framework.transports.mavlink_packets.packet_frame`). A truncated last
record (a killed recorder) ends the file and is counted (``truncated_log_tail``);
bytes that do not start a packet end the file too (``bad_tlog_records``), since
framing is lost there. Rotated files of one recording are read in order.
"""
from __future__ import annotations

import struct
from collections.abc import Iterator
from pathlib import Path

from ...messages import Message, RawFrame
from ...transports.mavlink_packets import packet_frame, packet_length
from ...transports.recorders import recording_set
from ...formats.base import ReaderError, ReadOptions

_STAMP = struct.Struct(">Q")


def tlog_frames(data: bytes, options: ReadOptions) -> Iterator[RawFrame]:
    """Every packet record of one tlog file's bytes as a RawFrame."""
    i, n = 0, len(data)
    while i < n:
        if i + 8 >= n:
            options.count("truncated_log_tail", 1)
            return
        t_us = _STAMP.unpack_from(data, i)[0]
        j = i + 8
        length = packet_length(data, j)
        if length is None:
            options.count("bad_tlog_records", 1)
            return
        if length < 0 or j + length > n:
            options.count("truncated_log_tail", 1)
            return
        yield packet_frame(t_us, data[j:j + length])
        i = j + length


class TlogReader:
    """MAVLink telemetry log -> RawFrames (see the module docstring)."""

    def __init__(self, path: Path, options: ReadOptions):
        self.files = recording_set(path)
        self.options = options
        with open(self.files[0], "rb") as fh:
            head = fh.read(9)
        if head and (len(head) == 9 and head[8] not in (0xFD, 0xFE)):
            raise ReaderError(f"{self.files[0]}: not a MAVLink tlog (expected 8 bytes of "
                              "time then a packet starting with 0xFD or 0xFE)")

    def __iter__(self) -> Iterator[tuple[str, Message]]:
        for path in self.files:
            for frame in tlog_frames(path.read_bytes(), self.options):
                yield "raw", frame


READERS = {".tlog": TlogReader}
FORMATS = {"tlog": TlogReader}
