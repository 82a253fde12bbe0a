"""The contract between a transport and :class:`~.live_source.LiveSource`.

A :class:`Link` delivers *arrivals* ``(t_us, native)``: the receive time in UNIX
microseconds (from :mod:`.clock`) and the transport's own object (a ``can.Message``,
a MAVLink message, a ``(device, bytes)`` line). The source records the native object,
then converts it with :meth:`Link.to_frame`, the same pure function the log readers
use, so live and replayed frames are byte-identical.
"""
from __future__ import annotations

import socket
from abc import ABC, abstractmethod
from typing import Any

from ..messages import RawFrame


class LinkLost(ConnectionError):
    """The link went away (cable unplugged, port closed); the source reconnects."""


class Link(ABC):
    """One live transport connection."""

    #: RawFrame.transport of this link's frames.
    transport: str = ""

    @abstractmethod
    def open(self) -> None:
        """Connect; raise any exception if the device is not there (retried later)."""

    @abstractmethod
    def read(self, timeout: float) -> list[tuple[int, Any]]:
        """Arrivals, waiting up to ``timeout`` seconds for the first; [] when none.

        Raises :class:`LinkLost` when the connection broke.
        """

    @abstractmethod
    def close(self) -> None:
        """Disconnect (idempotent)."""

    @abstractmethod
    def to_frame(self, t_us: int, native: Any) -> RawFrame | None:
        """The RawFrame of one arrival, or None when it is not a frame (bad data)."""

    @abstractmethod
    def health_key(self, native: Any) -> str:
        """The device stream this arrival belongs to, for link health."""

    def record_item(self, native: Any) -> Any:
        """What the recorder writes for this arrival (the native object by default)."""
        return native

    def write(self, data: bytes) -> None:
        """Send bytes on the link (links that can send override this)."""
        raise NotImplementedError(f"{type(self).__name__} cannot send")


def enlarge_receive_buffer(sock: socket.socket, size: int = 8 << 20) -> int:
    """Ask for a ``size``-byte socket receive buffer, so bursts are not dropped while
    the reading thread waits for the interpreter; returns the size obtained."""
    for opt in (getattr(socket, "SO_RCVBUFFORCE", None), socket.SO_RCVBUF):
        if opt is None:
            continue
        try:
            sock.setsockopt(socket.SOL_SOCKET, opt, size)
            break
        except OSError:
            continue
    return sock.getsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF)
