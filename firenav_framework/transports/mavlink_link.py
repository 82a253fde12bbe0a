"""MAVLink 2 through pymavlink (``udpin:``, ``udpout:``, ``tcp:``, ``tcpin:``, serial).

Every good packet becomes ``RawFrame(transport="mavlink", channel=msgid,
data=<complete packet bytes>, device="sys<sysid>/comp<compid>")`` stamped with the
receive time (:func:`.mavlink_packets.packet_frame`, which the tlog reader uses too);
packets with a bad CRC, bytes that start no packet and packets cut short are decode
errors (counted per kind under ``bad_data/<kind>``, never recorded). UDP is read and
framed datagram by datagram (:mod:`.mavlink_packets`: a damaged datagram cannot
swallow the next ones, and framing costs a few microseconds instead of pymavlink's
tens); serial and TCP streams go through pymavlink's parser.
HEARTBEATs are frames like any other (a sensor may use them); the link also sends its
own GCS heartbeat every ``heartbeat_s`` seconds so devices that wait for a ground
station start streaming (``udpin:`` learns where to send from the first packet).

:func:`mavutil` imports pymavlink's ``mavutil`` with ``MAVLINK20=1`` set first, as
MAVLink 2 messages (ODOMETRY) need.
"""
from __future__ import annotations

import os
import select
import time
from dataclasses import dataclass
from typing import Any

from ..messages import RawFrame
from . import clock
from .links import Link, LinkLost, enlarge_receive_buffer
from .mavlink_packets import packet_frame, packet_health_key, split_packets

MAX_BATCH = 2000


@dataclass(frozen=True)
class BadData:
    """An arrival that holds no usable packet: ``what`` went wrong (counted, not recorded)."""

    what: str


def mavutil() -> Any:
    """pymavlink's ``mavutil`` in MAVLink 2 mode."""
    os.environ["MAVLINK20"] = "1"
    from pymavlink import mavutil as mu
    return mu


def mavlink_frame(t_us: int, native: bytes | BadData) -> RawFrame | None:
    """The RawFrame of one received packet; None for bad data."""
    return None if isinstance(native, BadData) else packet_frame(t_us, native)


def mavlink_health_key(native: bytes | BadData) -> str:
    """See :func:`.mavlink_packets.packet_health_key`; bad data is ``bad_data/<kind>``."""
    if isinstance(native, BadData):
        return f"bad_data/{native.what}"
    return packet_health_key(native)


class MavlinkLink(Link):
    """A pymavlink connection string. UDP is read datagram by datagram and framed here
    (:mod:`.mavlink_packets`); streams (serial, TCP) through pymavlink's parser.
    Arrivals are packet bytes (or :class:`BadData`)."""

    transport = "mavlink"

    def __init__(self, url: str, *, baud: int = 115200, source_system: int = 255,
                 source_component: int = 190, heartbeat_s: float = 1.0):
        self.url = url
        self.baud = baud
        self.source_system = source_system
        self.source_component = source_component
        self.heartbeat_s = heartbeat_s
        self.conn: Any = None
        self._udp = False
        self._next_heartbeat = 0.0

    def open(self) -> None:
        mu = mavutil()
        self.conn = mu.mavlink_connection(self.url, baud=self.baud, input=True,
                                          source_system=self.source_system,
                                          source_component=self.source_component,
                                          autoreconnect=False)
        self._udp = isinstance(self.conn, mu.mavudp)
        if self._udp:
            enlarge_receive_buffer(self.conn.port)

    def _heartbeat(self) -> None:
        if self.heartbeat_s <= 0:
            return
        now = time.monotonic()
        if now >= self._next_heartbeat:
            self._next_heartbeat = now + self.heartbeat_s
            mu = mavutil()
            self.conn.mav.heartbeat_send(mu.mavlink.MAV_TYPE_GCS,
                                         mu.mavlink.MAV_AUTOPILOT_INVALID, 0, 0,
                                         mu.mavlink.MAV_STATE_ACTIVE)

    def read(self, timeout: float) -> list[tuple[int, Any]]:
        if self.conn is None:
            raise LinkLost("MAVLink connection is not open")
        try:
            self._heartbeat()
            if self._udp:
                return self._read_datagrams(timeout)
            out = self._drain_stream()
            if not out and self.conn.select(timeout):
                out = self._drain_stream()
            return out
        except (OSError, EOFError) as exc:
            raise LinkLost(f"MAVLink {self.url}: {exc}") from exc

    def _read_datagrams(self, timeout: float) -> list[tuple[int, Any]]:
        sock = self.conn.port
        out: list[tuple[int, Any]] = []
        if not select.select([sock], [], [], timeout)[0]:
            return out
        while len(out) < MAX_BATCH:
            try:
                data, addr = sock.recvfrom(65535)
            except (BlockingIOError, InterruptedError, ConnectionRefusedError):
                break  # drained (or an ICMP refusal from an udpout peer not listening yet)
            t_us = clock.now_us()
            self._note_peer(addr)
            split = split_packets(data)
            for pkt in split.packets:
                out.append((t_us, pkt))
                t_us = clock.now_us()
            for what, n in (("bad_crc", split.bad_crc), ("garbage", split.garbage),
                            ("truncated", split.truncated)):
                out += [(t_us, BadData(what))] * n
        return out

    def _note_peer(self, addr: tuple) -> None:
        """Where our heartbeats go, as pymavlink's own ``mavudp.recv`` records it."""
        c = self.conn
        if c.udp_server:
            c.clients.add(addr)
            c.clients_last_alive[addr] = time.time()
        elif c.broadcast:
            c.last_address = addr

    def _drain_stream(self) -> list[tuple[int, Any]]:
        out: list[tuple[int, Any]] = []
        while len(out) < MAX_BATCH:
            msg = self.conn.recv_msg()
            if msg is None:
                break
            native = (BadData("bad_data") if msg.get_type() == "BAD_DATA"
                      else bytes(msg.get_msgbuf()))
            out.append((clock.now_us(), native))
        return out

    def close(self) -> None:
        if self.conn is not None:
            try:
                self.conn.close()
            finally:
                self.conn = None

    def to_frame(self, t_us: int, native: bytes | BadData) -> RawFrame | None:
        return mavlink_frame(t_us, native)

    def health_key(self, native: bytes | BadData) -> str:
        return mavlink_health_key(native)

    def record_item(self, native: bytes | BadData) -> bytes | None:
        """The packet bytes for the tlog (None: bad data is counted, not recorded)."""
        return None if isinstance(native, BadData) else native
