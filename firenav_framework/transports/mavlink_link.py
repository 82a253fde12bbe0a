"""MAVLink 2 through pymavlink (``udpin:``, ``udpout:``, ``tcp:``, ``tcpin:``, serial).

Every good packet becomes ``RawFrame(transport="mavlink", channel=msgid,
data=<complete packet bytes>, device="sys<sysid>/comp<compid>")`` stamped with the
receive time; packets pymavlink rejects (bad CRC, garbage) are decode errors.
HEARTBEATs are frames like any other (a sensor may use them); the link also sends its
own GCS heartbeat every ``heartbeat_s`` seconds so devices that wait for a ground
station start streaming (``udpin:`` learns where to send from the first packet).

:func:`mavlink` imports pymavlink's ``mavutil`` with ``MAVLINK20=1`` set first, as
MAVLink 2 messages (ODOMETRY) need.
"""
from __future__ import annotations

import os
import time
from typing import Any

from ..messages import RawFrame
from . import clock
from .links import Link, LinkLost, enlarge_receive_buffer

MAX_BATCH = 2000


def mavutil() -> Any:
    """pymavlink's ``mavutil`` in MAVLink 2 mode."""
    os.environ["MAVLINK20"] = "1"
    from pymavlink import mavutil as mu
    return mu


def mavlink_frame(t_us: int, msg: Any) -> RawFrame | None:
    """The RawFrame of a parsed MAVLink message; None for data pymavlink rejected."""
    if msg.get_type() == "BAD_DATA":
        return None
    t = clock.seconds(t_us)
    return RawFrame(t=t, t_recv=t, transport="mavlink", channel=int(msg.get_msgId()),
                    data=bytes(msg.get_msgbuf()),
                    device=f"sys{msg.get_srcSystem()}/comp{msg.get_srcComponent()}")


def mavlink_health_key(msg: Any) -> str:
    """``sys<s>/comp<c>/<MSGNAME>``, plus ``/<id>`` for messages with an ``id`` field
    (HIGHRES_IMU of the left and right foot of one system are separate devices)."""
    kind = msg.get_type()
    if kind == "BAD_DATA":
        return "bad_data"
    key = f"sys{msg.get_srcSystem()}/comp{msg.get_srcComponent()}/{kind}"
    dev_id = getattr(msg, "id", None)
    return f"{key}/{dev_id}" if isinstance(dev_id, int) else key


class MavlinkLink(Link):
    """A pymavlink connection string, read without blocking the interpreter for long."""

    transport = "mavlink"

    def __init__(self, url: str, *, baud: int = 115200, source_system: int = 255,
                 source_component: int = 190, heartbeat_s: float = 1.0):
        self.url = url
        self.baud = baud
        self.source_system = source_system
        self.source_component = source_component
        self.heartbeat_s = heartbeat_s
        self.conn: Any = None
        self._next_heartbeat = 0.0

    def open(self) -> None:
        mu = mavutil()
        self.conn = mu.mavlink_connection(self.url, baud=self.baud, input=True,
                                          source_system=self.source_system,
                                          source_component=self.source_component,
                                          autoreconnect=False)
        sock = getattr(self.conn, "port", None)
        if hasattr(sock, "setsockopt") and self.url.startswith("udp"):
            enlarge_receive_buffer(sock)

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
            out = self._drain()
            if not out and self.conn.select(timeout):
                out = self._drain()
            return out
        except (OSError, EOFError) as exc:
            raise LinkLost(f"MAVLink {self.url}: {exc}") from exc

    def _drain(self) -> list[tuple[int, Any]]:
        out: list[tuple[int, Any]] = []
        while len(out) < MAX_BATCH:
            msg = self.conn.recv_msg()
            if msg is None:
                break
            out.append((clock.now_us(), msg))
        return out

    def close(self) -> None:
        if self.conn is not None:
            try:
                self.conn.close()
            finally:
                self.conn = None

    def to_frame(self, t_us: int, native: Any) -> RawFrame | None:
        return mavlink_frame(t_us, native)

    def health_key(self, native: Any) -> str:
        return mavlink_health_key(native)

    def record_item(self, native: Any) -> bytes | None:
        """The packet bytes for the tlog (None: bad data is counted, not recorded)."""
        return None if native.get_type() == "BAD_DATA" else native.get_msgbuf()
