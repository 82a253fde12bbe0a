"""Raw frames to disk as they arrive: rotating, crash-safe files in native formats.

Every recorder appends to ``<folder>/<prefix>-<NNNN>-<start time><suffix>``, opens the
next numbered file when the current one reaches ``rotate_bytes`` or ``rotate_s``
seconds of age, and hands its buffers to the operating system at least every
``flush_s`` seconds (``poll()`` is called by the source even when nothing arrives) and
whenever :meth:`~RotatingRecorder.flush` is called (the live sources call it after
each read, before the frames go on). A process killed with SIGKILL therefore loses
nothing that was flushed, at most the last ``flush_s`` of data, and every file stays
readable: the readers accept a truncated last record. Files are ``fsync``-ed when
they are closed or rotated (in a background thread: an fsync can take seconds).

Formats:

* :class:`CanRecorder`: any python-can log format by suffix (``.log`` candump,
  ``.asc``, ``.blf``, ``.trc``); candump ``.log`` is the default.
* :class:`TlogRecorder`: MAVLink ``.tlog`` as QGroundControl and MAVProxy write it: for
  each packet an 8-byte big-endian UNIX time in microseconds, then the packet bytes.
  (pymavlink's own tlog writing records nothing on UDP links, hence this one.)
* :class:`LinesRecorder`: ``.lines`` text, one arrival per line:
  ``<UNIX time, 6 decimals> <device> <data>``, the data with ``\\`` and every byte
  outside printable ASCII written as ``\\\\`` / ``\\xHH`` (see :func:`escape_bytes`).
"""
from __future__ import annotations

import copy
import datetime as _dt
import functools
import os
import re
import struct
import threading
import time
from abc import ABC, abstractmethod
from pathlib import Path
from typing import TYPE_CHECKING, IO, Any, Callable

if TYPE_CHECKING:
    import can

_INDEX = re.compile(r"-(\d{4,})-")
#: The file size is also checked (after a flush) every this many frames, so a burst
#: cannot overrun ``rotate_bytes`` by more than that many frames.
SIZE_CHECK_EVERY = 256


def log_files(folder: Path, suffixes: tuple[str, ...]) -> list[Path]:
    """Recorded files with one of ``suffixes`` in ``folder``, in recording order."""
    files = [p for p in Path(folder).iterdir() if p.is_file() and p.suffix.lower() in suffixes]

    def order(p: Path) -> tuple[int, str]:
        m = _INDEX.search(p.name)
        return (int(m.group(1)) if m else -1, p.name)

    return sorted(files, key=order)


class RotatingRecorder(ABC):
    """Appends arrivals ``(t_us, item)`` to numbered files; see the module docstring."""

    suffix: str = ""

    def __init__(self, folder: Path, prefix: str, *, rotate_bytes: int = 64 << 20,
                 rotate_s: float = 3600.0, flush_s: float = 0.1):
        if flush_s <= 0:
            raise ValueError(f"flush_s must be positive, got {flush_s}")
        self.folder = Path(folder)
        self.folder.mkdir(parents=True, exist_ok=True)
        self.prefix = prefix
        self.rotate_bytes = rotate_bytes
        self.rotate_s = rotate_s
        self.flush_s = flush_s
        self.files: list[Path] = []
        self.frames = 0
        self._open_path: Path | None = None
        self._opened_at = 0.0
        self._next_flush = 0.0
        self._rotate_due = False
        used = [int(m.group(1)) for p in self.folder.glob(f"{prefix}-*")
                if (m := _INDEX.search(p.name))]
        self._index = max(used, default=-1) + 1

    # -- the format -----------------------------------------------------------------
    @abstractmethod
    def _open(self, path: Path) -> None: ...

    @abstractmethod
    def _write(self, t_us: int, item: Any) -> None: ...

    @abstractmethod
    def _flush(self) -> None: ...

    @abstractmethod
    def _close(self) -> None: ...

    @abstractmethod
    def _fileno(self) -> int | None: ...

    @abstractmethod
    def _detach(self) -> Callable[[], None]:
        """Forget the current file; return a function that closes it (run in a thread)."""

    # -- the life cycle --------------------------------------------------------------
    def write(self, t_us: int, item: Any) -> None:
        """Record one arrival received at ``t_us`` (UNIX microseconds)."""
        if self._open_path is None or self._rotate_due:
            self._rotate()
        self._write(t_us, item)
        self.frames += 1
        self.poll(force=self.frames % SIZE_CHECK_EVERY == 0)

    def flush(self) -> None:
        """Hand everything written so far to the operating system (no fsync)."""
        if self._open_path is not None:
            self._flush()

    def poll(self, force: bool = False) -> None:
        """Flush if due (call regularly, also when nothing arrives); ``force`` flushes now."""
        if self._open_path is None:
            return
        now = time.monotonic()
        if now < self._next_flush and not force:
            return
        self._next_flush = now + self.flush_s
        self._flush()
        size = self._open_path.stat().st_size
        if size >= self.rotate_bytes or (self.rotate_s > 0 and now - self._opened_at >= self.rotate_s):
            self._rotate_due = True

    def close(self) -> None:
        """Flush, sync and close the current file (idempotent)."""
        if self._open_path is not None:
            self._flush()
            self._sync()
            self._close()
            self._open_path = None

    def _sync(self) -> None:
        fd = self._fileno()
        if fd is not None:
            try:
                os.fsync(fd)
            except OSError:
                pass

    def _rotate(self) -> None:
        if self._open_path is not None:  # sync the full file off the reading thread:
            self._flush()                # an fsync of a 64 MiB file can take seconds
            fd = self._fileno()
            closer = self._detach()
            self._open_path = None
            threading.Thread(target=_sync_and_close, args=(fd, closer), daemon=True).start()
        stamp = _dt.datetime.now().strftime("%Y%m%dT%H%M%S")
        path = self.folder / f"{self.prefix}-{self._index:04d}-{stamp}{self.suffix}"
        self._index += 1
        self._open(path)
        self._open_path = path
        self.files.append(path)
        self._opened_at = time.monotonic()
        self._next_flush = self._opened_at + self.flush_s
        self._rotate_due = False


def _sync_and_close(fd: int | None, closer) -> None:
    if fd is not None:
        try:
            os.fsync(fd)
        except OSError:
            pass
    closer()


class CanRecorder(RotatingRecorder):
    """CAN frames (``can.Message``, timestamp = receive time) in a python-can log format."""

    def __init__(self, folder: Path, prefix: str, *, suffix: str = ".log", **kw: Any):
        suffix = suffix if suffix.startswith(".") else "." + suffix
        if suffix.lower() not in CAN_LOG_SUFFIXES:
            raise ValueError(f"CAN log format '{suffix}' is not one python-can writes; "
                             f"choose one of {', '.join(CAN_LOG_SUFFIXES)}")
        self.suffix = suffix.lower()
        self._writer: Any = None
        super().__init__(folder, prefix, **kw)

    def _open(self, path: Path) -> None:
        import can   # python-can is imported by the recorders that use it

        if self.suffix == ".asc":
            self._writer = _padded_asc_writer()(str(path))
        else:
            self._writer = can.Logger(str(path))

    def _write(self, t_us: int, item: can.Message) -> None:
        if self.suffix != ".log":
            item = _numbered_channel(item)
        self._writer.on_message_received(item)

    def _flush(self) -> None:
        w = self._writer
        if hasattr(w, "_flush") and self.suffix == ".blf":
            w._flush()  # writes the pending compressed container
        fh = getattr(w, "file", None)
        if fh is not None:
            fh.flush()

    def _close(self) -> None:
        self._writer.stop()
        self._writer = None

    def _detach(self):
        writer, self._writer = self._writer, None
        return writer.stop

    def _fileno(self) -> int | None:
        fh = getattr(self._writer, "file", None)
        return fh.fileno() if fh is not None and not fh.closed else None


#: Largest channel number the binary formats hold (BLF keeps it in an unsigned 16-bit
#: field and writes it plus one).
_MAX_CHANNEL = 0xFFFE


def _numbered_channel(msg: can.Message) -> can.Message:
    """``msg`` as ASC/BLF/TRC can write it: they store channel numbers, which python-can
    takes from the trailing digits of the channel name ("can1" -> 1). A device named
    with a large number ("test-8a2f...932916") would make BLF fail, so such a message is
    written on the writer's default channel instead (the name is lost either way)."""
    import can

    number = can.util.channel2int(msg.channel)
    if number is None or 0 <= number <= _MAX_CHANNEL:
        return msg
    out = copy.copy(msg)
    out.channel = None
    return out


@functools.lru_cache(maxsize=1)
def _padded_asc_writer() -> type:
    """python-can's ASC writer with the milliseconds of its dates written as 3 digits.

    python-can 4.6 writes 38 ms as ``:11.38`` which every reader (its own included)
    parses as 380 ms, so a replay would start up to a second late. CANoe, too, expects
    three digits.
    """
    import can

    class PaddedAscWriter(can.ASCWriter):
        def _format_header_datetime(self, dt: _dt.datetime) -> str:
            return dt.strftime(self.FORMAT_DATE.format(f"{dt.microsecond // 1000:03d}"))

    return PaddedAscWriter


#: python-can log formats a :class:`CanRecorder` can write (and ``can_log`` reads).
CAN_LOG_SUFFIXES = (".log", ".asc", ".blf", ".trc")


class _FileRecorder(RotatingRecorder):
    """A recorder writing bytes to a plain buffered file."""

    _fh: IO[bytes] | None = None

    def _open(self, path: Path) -> None:
        self._fh = open(path, "ab")

    def _flush(self) -> None:
        self._fh.flush()

    def _close(self) -> None:
        self._fh.close()
        self._fh = None

    def _detach(self):
        fh, self._fh = self._fh, None
        return fh.close

    def _fileno(self) -> int | None:
        return self._fh.fileno() if self._fh is not None else None


class TlogRecorder(_FileRecorder):
    """MAVLink packets (bytes) as ``.tlog`` records: ``>Q`` microseconds + packet."""

    suffix = ".tlog"

    def _write(self, t_us: int, item: bytes) -> None:
        self._fh.write(struct.pack(">Q", t_us) + bytes(item))


class LinesRecorder(_FileRecorder):
    """Lines or datagrams ``(device, bytes)`` as ``.lines`` text records."""

    suffix = ".lines"

    def _write(self, t_us: int, item: tuple[str, bytes]) -> None:
        device, data = item
        if not device or any(c.isspace() for c in device):
            raise ValueError(f"a device name for a line log must be one word, got {device!r}")
        self._fh.write(b"%d.%06d %s %s\n" % (t_us // 1_000_000, t_us % 1_000_000,
                                             device.encode(), escape_bytes(data)))


_PLAIN = frozenset(range(0x21, 0x7F)) - {ord("\\")}
_ESCAPE_TABLE = [bytes([b]) if b in _PLAIN else b"\\x%02x" % b for b in range(256)]
_ESCAPE_TABLE[ord("\\")] = b"\\\\"
_ESCAPE_TABLE[ord(" ")] = b" "
_UNESCAPE = re.compile(rb"\\(\\|x[0-9a-fA-F]{2})")


def escape_bytes(data: bytes) -> bytes:
    """Printable ASCII (and spaces) as is, ``\\`` as ``\\\\``, everything else ``\\xHH``."""
    return b"".join(_ESCAPE_TABLE[b] for b in data)


def unescape_bytes(text: bytes) -> bytes:
    """The inverse of :func:`escape_bytes`."""
    return _UNESCAPE.sub(lambda m: b"\\" if m.group(1) == b"\\" else
                         bytes([int(m.group(1)[1:], 16)]), text)


def recording_set(path: Path) -> list[Path]:
    """The files of the rotated recording that ``path`` belongs to, from ``path`` on.

    A recorder's files are ``<prefix>-<NNNN>-<stamp><suffix>``; a reader given one of
    them continues through the later-numbered files of the same prefix and suffix in
    the same folder (a rotation splits one recording, it does not make new ones). Any
    other file name is read alone.
    """
    path = Path(path)
    m = _INDEX.search(path.name)
    if m is None:
        return [path]
    prefix, index = path.name[:m.start()], int(m.group(1))
    out = []
    for p in log_files(path.parent, (path.suffix.lower(),)):
        pm = _INDEX.search(p.name)
        if pm and p.name[:pm.start()] == prefix and int(pm.group(1)) >= index:
            out.append(p)
    return out or [path]
