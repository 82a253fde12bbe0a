"""Reader of MAVLink ``.tlog`` files: 8-byte big-endian UNIX microseconds + packet.

Packets are framed by their own header (MAVLink 1 ``0xFE``, MAVLink 2 ``0xFD`` with
its optional 13-byte signature), so the reader is fast; each becomes the RawFrame the
live ``mavlink`` source made of it (the same function,
:func:`~firenav_framework.transports.mavlink_packets.packet_frame`). A truncated last
record (a killed recorder) ends the file and is counted (``truncated_log_tail``).

Damage in the middle (bytes that do not start a record) costs only the damaged bytes:
the reader resynchronises on the next record whose packet checksum is right (and whose
message id the dialect knows), counting each damaged region once (``bad_tlog_records``)
and the bytes it skipped (``skipped_bytes``), and warns once per file. An empty file is
reported (``empty_log``). Rotated files of one recording are read in order.
"""
from __future__ import annotations

import struct
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from ...messages import Message, RawFrame
from ...transports.mavlink_packets import (MAGIC_V1, MAGIC_V2, checksum_ok, packet_frame,
                                           packet_length)
from ...transports.recorders import recording_set
from ...formats.base import ReaderError, ReadOptions

_STAMP = struct.Struct(">Q")


def _record_at(data: bytes, arr: np.ndarray, i: int) -> int | None:
    """Length of the packet of a whole, checksum-right record at ``i``, else None."""
    j = i + 8
    if j >= len(data) or data[j] not in (MAGIC_V1, MAGIC_V2):
        return None
    length = packet_length(data, j)
    if length is None or length < 0 or j + length > len(data):
        return None
    return length if checksum_ok(arr, j, data[j:j + length]) else None


def _resync(data: bytes, arr: np.ndarray, i: int) -> int:
    """Offset of the next whole, checksum-right record after ``i`` (``len(data)``: none)."""
    n = len(data)
    for magic in np.flatnonzero((arr[i + 9:] == MAGIC_V1) | (arr[i + 9:] == MAGIC_V2)):
        k = i + 1 + int(magic)  # the record starts 8 bytes before its magic
        if k + 8 < n and _record_at(data, arr, k) is not None:
            return k
    return n


def tlog_frames(data: bytes, options: ReadOptions, name: str = "tlog") -> Iterator[RawFrame]:
    """Every packet record of one tlog file's bytes as a RawFrame (see the module)."""
    i, n = 0, len(data)
    arr = np.frombuffer(data, np.uint8)
    regions = 0
    while i < n:
        if i + 8 >= n:
            options.count("truncated_log_tail", 1)
            break
        t_us = _STAMP.unpack_from(data, i)[0]
        j = i + 8
        length = packet_length(data, j)
        if length is not None and 0 <= length and j + length > n:
            options.count("truncated_log_tail", 1)   # a torn last record
            break
        if length is None or length < 0:
            nxt = _resync(data, arr, i)
            if nxt >= n and n - i < 300:  # no whole record follows: a torn tail
                options.count("truncated_log_tail", 1)
                break
            regions += 1
            options.count("bad_tlog_records", 1)
            options.count("skipped_bytes", nxt - i)
            if regions == 1:
                options.warn("damaged_log", f"{name}: {nxt - i} damaged bytes at offset {i} "
                             "skipped; reading resumed at the next whole record")
            i = nxt
            continue
        yield packet_frame(t_us, data[j:j + length])
        i = j + length


class TlogReader:
    """MAVLink telemetry log -> RawFrames (see the module docstring)."""

    def __init__(self, path: Path, options: ReadOptions):
        self.files = recording_set(path)
        self.options = options
        with open(self.files[0], "rb") as fh:
            head = fh.read(9)
        if head and (len(head) == 9 and head[8] not in (MAGIC_V1, MAGIC_V2)):
            raise ReaderError(f"{self.files[0]}: not a MAVLink tlog (expected 8 bytes of "
                              "time then a packet starting with 0xFD or 0xFE)")
        if not head:
            options.warn("empty_log", f"{self.files[0]}: empty log, no MAVLink records")

    def __iter__(self) -> Iterator[tuple[str, Message]]:
        for path in self.files:
            for frame in tlog_frames(path.read_bytes(), self.options, str(path)):
                yield "raw", frame


READERS = {".tlog": TlogReader}
FORMATS = {"tlog": TlogReader}
