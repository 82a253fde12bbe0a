"""Reader of CAN logs (python-can formats) written by the ``can_bus`` source.

Yields ``("raw", RawFrame)`` exactly as the live source produced them (same
conversion, :func:`~firenav_framework.transports.can_link.can_frame`), continuing
through the rotated files of the same recording
(:func:`~firenav_framework.transports.recorders.recording_set`). Timestamps are
rounded to the microsecond the live source used, which undoes the nanosecond float
error of formats that store offsets (BLF): candump ``.log`` and BLF give back
the live times exactly; ASC stores its start time to 1 ms, so its times come back
shifted by one constant below 1 ms (intervals exact to 1 us). Device names survive
in candump ``.log`` (the default); ASC and BLF store channel numbers, so frames read
from them carry ``can<N>``-style names. Error frames are counted (``can_error_frames``), not passed on.

Damage costs only itself: in the text formats (candump, ASC, TRC) a line python-can
cannot parse is skipped and reading goes on with the next line; in BLF a damaged
object or compressed container is skipped and reading goes on at the next object
signature (a container holds up to 128 kB of frames, the granularity of that format).
Each damaged region is counted once (``damaged_regions``; ``skipped_lines`` /
``skipped_bytes`` say how much) and warned about once per file; an empty log is
reported (``empty_log``). A damaged last line or object (a killed recorder) is
counted as ``truncated_log_tail``.
"""
from __future__ import annotations

import copy
import logging
import struct
import zlib
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import can
from can.io import blf

from ...messages import Message
from ...transports.can_link import can_frame
from ...transports.recorders import recording_set
from ...formats.base import ReaderError, ReadOptions

# python-can's TRC reader logs every line it cannot parse, with its bytes: counted here
logging.getLogger("can.io.trc").setLevel(logging.ERROR)

#: python-can's readers of the line formats, by suffix (others: binary).
TEXT_READERS: dict[str, Any] = {".log": can.CanutilsLogReader, ".asc": can.ASCReader,
                                ".trc": can.TRCReader}


class CanLogReader:
    """python-can log -> RawFrames (see the module docstring)."""

    def __init__(self, path: Path, options: ReadOptions):
        self.files = recording_set(path)
        self.options = options
        try:
            first = next(iter(_messages(self.files[0], ReadOptions())), None)
        except Exception as exc:
            raise ReaderError(f"{self.files[0]}: not a readable CAN log "
                              f"({type(exc).__name__}: {exc})") from exc
        if first is None and len(self.files) == 1:
            options.warn("empty_log", f"{self.files[0]}: no CAN frames in this log")

    def __iter__(self) -> Iterator[tuple[str, Message]]:
        for path in self.files:
            for msg in _messages(path, self.options):
                t_us = round(msg.timestamp * 1e6)
                if isinstance(msg.channel, int) or (isinstance(msg.channel, str)
                                                    and msg.channel.isdigit()):
                    msg.channel = f"can{msg.channel}"
                frame = can_frame(t_us, msg)
                if frame is None:
                    self.options.count("can_error_frames", 1)
                    continue
                yield "raw", frame


def _messages(path: Path, options: ReadOptions) -> Iterator[can.Message]:
    """The frames of one log file, resuming after damage (see the module docstring)."""
    suffix = path.suffix.lower()
    if suffix == ".blf":
        with open(path, "rb") as fh:
            yield from _TolerantBlfReader(fh, path, options)
        return
    cls = TEXT_READERS.get(suffix)
    if cls is None:
        raise ReaderError(f"{path}: not a CAN log format firenav reads ({suffix})")
    kw = {"relative_timestamp": False} if cls is can.ASCReader else {}
    with open(path, encoding="utf-8", errors="replace", newline=None) as fh:
        yield from _resuming_lines(cls(fh, **kw), fh, path, options)


def _resuming_lines(reader: Any, fh: Any, path: Path, options: ReadOptions
                    ) -> Iterator[can.Message]:
    """A line reader's frames; after a line it cannot parse, a copy of the reader (same
    header state) continues on the same file with the next line."""
    damaged, warned = 0, False
    while True:
        it = iter(reader)
        try:
            for msg in it:
                damaged = 0
                yield msg
            return
        except (ValueError, IndexError, KeyError, TypeError, AttributeError):  # a bad line
            if damaged == 0:
                options.count("damaged_regions", 1)
                if not warned:
                    warned = True
                    options.warn("damaged_log", f"{path}: lines python-can cannot read "
                                 "skipped; reading resumed after them")
            damaged += 1
            options.count("skipped_lines", 1)
            reader = copy.copy(reader)
            reader._extract_header = lambda: None  # the header was read already


class _TolerantBlfReader(blf.BLFReader):
    """python-can's BLF reader that skips damaged objects and containers (resuming at the
    next ``LOBJ`` signature) instead of ending the file there."""

    def __init__(self, fh: Any, path: Path, options: ReadOptions):
        super().__init__(fh)
        self.path, self.options = path, options
        self._damage = False
        self._warned = False

    def _damaged(self, skipped: int, at: int) -> None:
        if not self._damage:
            self.options.count("damaged_regions", 1)
            if not self._warned:
                self._warned = True
                self.options.warn("damaged_log", f"{self.path}: a damaged object at byte "
                                  f"{at} skipped; reading resumed at the next one")
        self._damage = True
        self.options.count("skipped_bytes", skipped)
        self._tail = b""

    def _seek_signature(self, start: int) -> bool:
        """Move the file to the next ``LOBJ`` at or after ``start``; False at the end."""
        self.file.seek(start)
        carry = b""
        while True:
            chunk = self.file.read(1 << 16)
            if not chunk:
                return False
            buf = carry + chunk
            k = buf.find(b"LOBJ")
            if k >= 0:
                self.file.seek(start - len(carry) + k)
                return True
            start += len(chunk)
            carry = buf[-3:]

    def __iter__(self) -> Iterator[can.Message]:
        head = blf.OBJ_HEADER_BASE_STRUCT
        while True:
            at = self.file.tell()
            data = self.file.read(head.size)
            if not data:
                return
            if len(data) < head.size:
                self.options.count("truncated_log_tail", 1)
                return
            signature, _, _, obj_size, obj_type = head.unpack(data)
            obj_data = self.file.read(max(0, obj_size - head.size)) if signature == b"LOBJ" \
                else b""
            if signature != b"LOBJ" or obj_size < head.size or \
                    len(obj_data) < obj_size - head.size:
                if signature == b"LOBJ" and len(obj_data) < obj_size - head.size and \
                        b"LOBJ" not in obj_data:
                    self.options.count("truncated_log_tail", 1)  # the last object, torn
                    return
                if not self._seek_signature(at + 1):
                    self._damaged(self.file.tell() - at, at)
                    return
                self._damaged(self.file.tell() - at, at)
                continue
            self.file.read(obj_size % 4)  # padding
            if obj_type != blf.LOG_CONTAINER:
                continue
            whole = True
            try:
                method, _ = blf.LOG_CONTAINER_STRUCT.unpack_from(obj_data)
                payload = obj_data[blf.LOG_CONTAINER_STRUCT.size:]
                if method == blf.ZLIB_DEFLATE:
                    payload, whole = _inflate(payload)
                elif method != blf.NO_COMPRESSION:
                    continue
                frames = list(self._parse_container(payload))
            except (struct.error, blf.BLFParseError, ValueError):
                frames, whole = [], False
            if whole:
                self._damage = False
            else:  # what was readable before the damage is kept
                self._damaged(obj_size, at)
            yield from frames


def _inflate(payload: bytes) -> tuple[bytes, bool]:
    """A container's zlib data inflated as far as it is readable; (data, whether whole)."""
    inflater, out = zlib.decompressobj(), []
    for k in range(0, len(payload), 4096):
        try:
            out.append(inflater.decompress(payload[k:k + 4096]))
        except zlib.error:
            return b"".join(out), False
    return b"".join(out) + inflater.flush(), inflater.eof


READERS = {".log": CanLogReader, ".asc": CanLogReader, ".blf": CanLogReader,
           ".trc": CanLogReader}
FORMATS = {"candump": CanLogReader, "can_asc": CanLogReader, "can_blf": CanLogReader,
           "can_trc": CanLogReader}
