"""Plain serial and UDP line protocols of vendor devices (UWB modules, RFID readers).

One line (serial) or one line of a datagram (UDP) becomes ``RawFrame(transport=
"serial"|"udp", channel="", data=<the line without its terminator>, device=...)``
stamped with the receive time. The device is the link's name for a serial port and
the sender's ``host:port`` for UDP. A line longer than ``max_line`` bytes is a
decode error (its bytes so far are dropped, counted, and reading resynchronises at
the next terminator).
"""
from __future__ import annotations

import socket
from typing import Any

import serial

from ..messages import RawFrame
from . import clock
from .links import Link, LinkLost, enlarge_receive_buffer

#: Bytes taken per read once data is there.
READ_CHUNK = 65536
#: Marks a line dropped for being too long (counted as a decode error, not recorded).
OVERLONG = object()


def line_frame(t_us: int, native: tuple[str, bytes], transport: str) -> RawFrame | None:
    """The RawFrame of one received (or logged) line ``(device, data)``."""
    device, data = native
    t = clock.seconds(t_us)
    return RawFrame(t=t, t_recv=t, transport=transport, channel="", data=bytes(data),
                    device=device)


class _Splitter:
    """Cuts a byte stream into lines at ``terminator``; drops lines over ``max_line``."""

    def __init__(self, terminator: bytes, max_line: int, strip_cr: bool):
        if not terminator:
            raise ValueError("the line terminator must not be empty")
        self.terminator = terminator
        self.max_line = max_line
        self.strip_cr = strip_cr and terminator == b"\n"
        self.buf = bytearray()
        self.skipping = False

    def feed(self, data: bytes) -> list[Any]:
        self.buf += data
        out: list[Any] = []
        while True:
            i = self.buf.find(self.terminator)
            if i < 0:
                if len(self.buf) > self.max_line:
                    if not self.skipping:
                        out.append(OVERLONG)
                    self.skipping = True
                    self.buf.clear()
                return out
            line = bytes(self.buf[:i])
            del self.buf[:i + len(self.terminator)]
            if self.skipping:
                self.skipping = False
                continue
            if len(line) > self.max_line:
                out.append(OVERLONG)
                continue
            if self.strip_cr and line.endswith(b"\r"):
                line = line[:-1]
            out.append(line)


class SerialLineLink(Link):
    """A serial port (or any pyserial URL: ``loop://``, ``socket://host:port``, ``rfc2217://``)."""

    transport = "serial"

    def __init__(self, url: str, *, device: str, baudrate: int = 115200,
                 terminator: bytes = b"\n", max_line: int = 4096, strip_cr: bool = True):
        self.url = url
        self.device = device
        self.baudrate = baudrate
        self.splitter_args = (terminator, max_line, strip_cr)
        self.port: serial.SerialBase | None = None
        self.splitter = _Splitter(*self.splitter_args)

    def open(self) -> None:
        self.port = serial.serial_for_url(self.url, baudrate=self.baudrate, timeout=0.1)
        self.splitter = _Splitter(*self.splitter_args)

    def read(self, timeout: float) -> list[tuple[int, Any]]:
        if self.port is None:
            raise LinkLost("serial port is not open")
        try:  # wait for the first byte, then take whatever else is there
            self.port.timeout = timeout
            data = self.port.read(1)
            if data:
                self.port.timeout = 0
                data += self.port.read(READ_CHUNK)
        except (serial.SerialException, OSError) as exc:
            raise LinkLost(f"serial {self.url}: {exc}") from exc
        if not data:
            return []
        t_us = clock.now_us()
        out = []
        for line in self.splitter.feed(data):
            out.append((t_us, line if line is OVERLONG else (self.device, line)))
            t_us = clock.now_us()
        return out

    def write(self, data: bytes) -> None:
        if self.port is None:
            raise LinkLost("serial port is not open")
        self.port.write(data)

    def close(self) -> None:
        if self.port is not None:
            try:
                self.port.close()
            finally:
                self.port = None

    def to_frame(self, t_us: int, native: Any) -> RawFrame | None:
        return None if native is OVERLONG else line_frame(t_us, native, self.transport)

    def health_key(self, native: Any) -> str:
        return self.device

    def record_item(self, native: Any) -> Any:
        return None if native is OVERLONG else native


class UdpLineLink(Link):
    """A UDP socket bound to ``host:port``; each datagram holds one or more lines."""

    transport = "udp"

    def __init__(self, bind: str, *, terminator: bytes = b"\n", max_line: int = 4096,
                 strip_cr: bool = True):
        host, _, port = bind.rpartition(":")
        if not host or not port.isdigit():
            raise ValueError(f"bind must be HOST:PORT, got {bind!r}")
        self.address = (host, int(port))
        self.terminator, self.max_line, self.strip_cr = terminator, max_line, strip_cr
        self.sock: socket.socket | None = None

    def open(self) -> None:
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind(self.address)
        enlarge_receive_buffer(sock)
        self.sock = sock

    @property
    def port(self) -> int:
        """The bound port (useful with port 0)."""
        return self.sock.getsockname()[1] if self.sock else self.address[1]

    def read(self, timeout: float) -> list[tuple[int, Any]]:
        if self.sock is None:
            raise LinkLost("UDP socket is not open")
        out: list[tuple[int, Any]] = []
        self.sock.settimeout(timeout)
        try:
            while len(out) < 2000:
                try:
                    data, (host, port) = self.sock.recvfrom(65535)
                except (socket.timeout, BlockingIOError):
                    break
                t_us = clock.now_us()
                # a datagram is complete: its last line needs no terminator
                splitter = _Splitter(self.terminator, self.max_line, self.strip_cr)
                lines = splitter.feed(data if data.endswith(self.terminator)
                                      else data + self.terminator)
                for line in lines:
                    out.append((t_us, line if line is OVERLONG else (f"{host}:{port}", line)))
                    t_us = clock.now_us()
                self.sock.settimeout(0)
        except OSError as exc:
            raise LinkLost(f"UDP {self.address}: {exc}") from exc
        return out

    def close(self) -> None:
        if self.sock is not None:
            self.sock.close()
            self.sock = None

    def to_frame(self, t_us: int, native: Any) -> RawFrame | None:
        return None if native is OVERLONG else line_frame(t_us, native, self.transport)

    def health_key(self, native: Any) -> str:
        return "overlong" if native is OVERLONG else native[0]

    def record_item(self, native: Any) -> Any:
        return None if native is OVERLONG else native


class UdpLineSender:
    """Sends each write as one datagram to ``host:port`` (the devices' side of a
    :class:`UdpLineLink`)."""

    def __init__(self, address: str):
        host, _, port = address.rpartition(":")
        if not host or not port.isdigit():
            raise ValueError(f"UDP line output must be udp:HOST:PORT, got udp:{address}")
        self.address = (host, int(port))
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)

    def write(self, data: bytes) -> None:
        self.sock.sendto(data, self.address)

    def close(self) -> None:
        self.sock.close()


def open_line_output(url: str) -> Any:
    """Where a player writes text lines: ``udp:HOST:PORT`` (one datagram per line) or a
    serial port (a device path such as a pty, or any pyserial URL); the object has
    ``write(bytes)`` and ``close()``."""
    if url.startswith("udp:"):
        return UdpLineSender(url[4:])
    return serial.serial_for_url(url, baudrate=115200)
