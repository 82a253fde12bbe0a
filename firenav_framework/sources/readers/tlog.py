"""Reader of MAVLink ``.tlog`` files: 8-byte big-endian UNIX microseconds + packet.

Packets are framed by their own header (MAVLink 1 ``0xFE``, MAVLink 2 ``0xFD`` with
its optional 13-byte signature), so the reader needs no dialect and is fast; each
becomes the RawFrame the live ``mavlink`` source made of it (same time, msgid,
system/component and bytes). A truncated last record (a killed recorder) ends the
file and is counted (``truncated_log_tail``); bytes that do not start a packet end
the file too (``bad_tlog_records``), since framing is lost there. Rotated files of
one recording are read in order.
"""
from __future__ import annotations

import struct
from collections.abc import Iterator
from pathlib import Path

from ...messages import Message, RawFrame
from ...transports import clock
from ...transports.recorders import recording_set
from .base import ReaderError, ReadOptions

_STAMP = struct.Struct(">Q")


def _packet_length(buf: bytes | memoryview, i: int) -> int | None:
    """Total length of the MAVLink packet starting at ``buf[i]`` (None: not a packet)."""
    magic = buf[i]
    if magic == 0xFD:
        if i + 3 > len(buf):
            return -1
        return 10 + buf[i + 1] + 2 + (13 if buf[i + 2] & 0x01 else 0)
    if magic == 0xFE:
        if i + 2 > len(buf):
            return -1
        return 6 + buf[i + 1] + 2
    return None


def tlog_frames(data: bytes, options: ReadOptions) -> Iterator[RawFrame]:
    """Every packet record of one tlog file's bytes as a RawFrame."""
    i, n = 0, len(data)
    while i < n:
        if i + 8 >= n:
            options.count("truncated_log_tail", 1)
            return
        t_us = _STAMP.unpack_from(data, i)[0]
        j = i + 8
        length = _packet_length(data, j)
        if length is None:
            options.count("bad_tlog_records", 1)
            return
        if length < 0 or j + length > n:
            options.count("truncated_log_tail", 1)
            return
        pkt = data[j:j + length]
        if pkt[0] == 0xFD:
            sysid, compid = pkt[5], pkt[6]
            msgid = pkt[7] | (pkt[8] << 8) | (pkt[9] << 16)
        else:
            sysid, compid, msgid = pkt[3], pkt[4], pkt[5]
        t = clock.seconds(t_us)
        yield RawFrame(t=t, t_recv=t, transport="mavlink", channel=msgid, data=pkt,
                       device=f"sys{sysid}/comp{compid}")
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
