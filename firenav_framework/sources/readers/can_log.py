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
"""
from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import can

from ...messages import Message
from ...transports.can_link import can_frame
from ...transports.recorders import recording_set
from ...formats.base import ReaderError, ReadOptions


class CanLogReader:
    """python-can log -> RawFrames (see the module docstring)."""

    def __init__(self, path: Path, options: ReadOptions):
        self.files = recording_set(path)
        self.options = options
        try:
            next(iter(_open(self.files[0])), None)
        except Exception as exc:
            raise ReaderError(f"{self.files[0]}: not a readable CAN log "
                              f"({type(exc).__name__}: {exc})") from exc

    def __iter__(self) -> Iterator[tuple[str, Message]]:
        for path in self.files:
            reader = _open(path)
            try:
                for msg in _tolerant(reader, path, self.options):
                    t_us = round(msg.timestamp * 1e6)
                    if isinstance(msg.channel, int) or (isinstance(msg.channel, str)
                                                        and msg.channel.isdigit()):
                        msg.channel = f"can{msg.channel}"
                    frame = can_frame(t_us, msg)
                    if frame is None:
                        self.options.count("can_error_frames", 1)
                        continue
                    yield "raw", frame
            finally:
                reader.stop()


def _open(path: Path) -> can.io.generic.MessageReader:
    """python-can's reader for ``path``, with absolute timestamps (ASC defaults to relative)."""
    if path.suffix.lower() == ".asc":
        return can.LogReader(str(path), relative_timestamp=False)
    return can.LogReader(str(path))


def _tolerant(reader: can.io.generic.MessageReader, path: Path,
              options: ReadOptions) -> Iterator[can.Message]:
    """The reader's messages; a damaged tail (a killed recorder) ends the file, counted."""
    it = iter(reader)
    while True:
        try:
            msg = next(it)
        except StopIteration:
            return
        except Exception:
            options.count("truncated_log_tail", 1)
            return
        yield msg


READERS = {".log": CanLogReader, ".asc": CanLogReader, ".blf": CanLogReader,
           ".trc": CanLogReader}
FORMATS = {"candump": CanLogReader, "can_asc": CanLogReader, "can_blf": CanLogReader,
           "can_trc": CanLogReader}
