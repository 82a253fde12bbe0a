"""CAN through python-can: any interface by name and channel (socketcan, pcan, kvaser,
slcan/serial, virtual, udp_multicast, ...).

Frames become ``RawFrame(transport="can", channel=arbitration_id, data=payload,
device=<link device name>)`` with ``t = t_recv =`` the receive time on the shared
clock (the interface's own timestamp is replaced: it is on another clock for some
interfaces, and the log must hold the time the pipeline used). Error frames are
counted as decode errors and recorded, never passed on.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any

from ..messages import RawFrame
from . import clock
from .links import Link, LinkLost, enlarge_receive_buffer

if TYPE_CHECKING:
    import can

#: At most this many frames are taken per read, so silence checks and flushes run.
MAX_BATCH = 2000


def can_frame(t_us: int, msg: can.Message) -> RawFrame | None:
    """The RawFrame of a received (or logged) CAN message; None for error frames."""
    if msg.is_error_frame:
        return None
    t = clock.seconds(t_us)
    return RawFrame(t=t, t_recv=t, transport="can", channel=int(msg.arbitration_id),
                    data=bytes(msg.data), device=str(msg.channel or ""))


def can_health_key(msg: can.Message) -> str:
    if msg.is_error_frame:
        return f"{msg.channel}/error"
    return f"{msg.channel}/0x{msg.arbitration_id:03X}"


class CanLink(Link):
    """A python-can bus opened with ``can.Bus(interface=..., channel=..., **options)``."""

    transport = "can"

    def __init__(self, interface: str, channel: str, *, device: str = "",
                 bitrate: int | None = None, options: dict[str, Any] | None = None):
        self.interface = interface
        self.channel = channel
        self.device = device or str(channel)
        self.bitrate = bitrate
        self.options = dict(options or {})
        self.bus: can.BusABC | None = None

    def open(self) -> None:
        import can   # python-can is imported by the links that use it, not by every run

        kw = dict(self.options)
        if self.bitrate is not None:
            kw["bitrate"] = self.bitrate
        self.bus = can.Bus(interface=self.interface, channel=self.channel, **kw)
        sock = getattr(getattr(self.bus, "_multicast", None), "_socket", None)
        if sock is not None:  # udp_multicast: survive bursts while the GIL is busy
            enlarge_receive_buffer(sock)

    def read(self, timeout: float) -> list[tuple[int, Any]]:
        import can

        if self.bus is None:
            raise LinkLost("CAN bus is not open")
        try:
            msg = self.bus.recv(timeout)
            out: list[tuple[int, Any]] = []
            while msg is not None:
                t_us = clock.now_us()
                msg.timestamp = clock.seconds(t_us)
                msg.channel = self.device
                out.append((t_us, msg))
                if len(out) >= MAX_BATCH:
                    break
                msg = self.bus.recv(0)
            return out
        except can.CanOperationError as exc:
            raise LinkLost(f"CAN {self.interface}:{self.channel}: {exc}") from exc

    def close(self) -> None:
        if self.bus is not None:
            try:
                self.bus.shutdown()
            finally:
                self.bus = None

    def to_frame(self, t_us: int, native: can.Message) -> RawFrame | None:
        return can_frame(t_us, native)

    def health_key(self, native: can.Message) -> str:
        return can_health_key(native)
