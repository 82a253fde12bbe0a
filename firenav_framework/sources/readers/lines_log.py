"""Reader of ``.lines`` logs written by the ``serial_lines`` and ``udp_lines`` sources.

Each record is ``<UNIX seconds with 6 decimals> <device> <escaped data>``; the file
name's prefix (``serial-`` or ``udp-``) gives the transport. Frames are the ones the
live source made (same conversion). A record that cannot be parsed (a torn last line
after a crash, a hand-edited line, a damaged region) is skipped and counted
(``bad_log_lines``), and reading goes on with the next line. An empty log is reported
(``empty_log``). Rotated files of one recording are read in order.
"""
from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

from ...messages import Message
from ...transports.line_links import line_frame
from ...transports.recorders import recording_set, unescape_bytes
from ...formats.base import ReadOptions

TRANSPORTS = ("serial", "udp")


class LinesLogReader:
    """Line log -> RawFrames (see the module docstring)."""

    def __init__(self, path: Path, options: ReadOptions):
        self.files = recording_set(path)
        self.options = options
        prefix = self.files[0].name.split("-", 1)[0]
        self.transport = prefix if prefix in TRANSPORTS else "serial"
        if len(self.files) == 1 and self.files[0].stat().st_size == 0:
            options.warn("empty_log", f"{self.files[0]}: empty log, no lines in it")

    def __iter__(self) -> Iterator[tuple[str, Message]]:
        for path in self.files:
            with open(path, "rb") as fh:
                for line in fh:
                    native = _parse(line)
                    if native is None:
                        self.options.count("bad_log_lines", 1)
                        continue
                    yield "raw", line_frame(native[0], native[1], self.transport)


def _parse(line: bytes) -> tuple[int, tuple[str, bytes]] | None:
    if not line.endswith(b"\n"):
        return None
    parts = line[:-1].split(b" ", 2)
    if len(parts) != 3:
        return None
    stamp, device, data = parts
    sec, dot, frac = stamp.partition(b".")
    if not (sec.isdigit() and dot and len(frac) == 6 and frac.isdigit()):
        return None
    return int(sec) * 1_000_000 + int(frac), (device.decode("utf-8", "replace"),
                                              unescape_bytes(data))


READERS = {".lines": LinesLogReader}
FORMATS = {"lines": LinesLogReader}
