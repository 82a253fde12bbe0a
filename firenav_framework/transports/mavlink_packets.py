"""MAVLink packets as bytes: framing, CRC check, RawFrames and health keys, no message objects.

The live MAVLink link (UDP) and the ``.tlog`` reader both cut packets out of bytes
with :func:`split_packets` and turn each into a RawFrame with :func:`packet_frame`, so a
replayed frame is byte-identical to the live one. Framing follows the packet's own
header (MAVLink 1 ``0xFE``, MAVLink 2 ``0xFD`` with its optional 13-byte signature);
the checksum (CRC-16/MCRF4XX over the packet after the magic byte plus the message's
``crc_extra``) is checked with a numba kernel (pymavlink's pure-Python CRC costs
more than everything else per packet). As in pymavlink, a message id the dialect
does not know cannot be checked and is rejected (a corrupt header mostly looks like
one); set ``MAVLINK_DIALECT`` for a vendor dialect.

On UDP a datagram is a unit: a packet cut short at its end is counted as truncated
and parsing starts afresh with the next datagram, so one damaged datagram cannot
swallow the packets that follow (pymavlink's stream parser would).
"""
from __future__ import annotations

import functools
import re
import struct
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..codecs.mavlink_payloads import MAGIC_V1, MAGIC_V2, SIGNATURE_LEN, crc_ok
from ..messages import RawFrame
from . import clock


@dataclass(frozen=True)
class Dialect:
    """What framing needs of a pymavlink dialect, per message id."""

    crc_extra: dict[int, int]
    names: dict[int, str]
    id_offset: dict[int, int]  # payload offset of a uint8 ``id`` field (left/right IMU)


@functools.lru_cache(maxsize=1)
def dialect() -> Dialect:
    """The tables of the dialect pymavlink's ``mavutil`` loads (MAVLink 2 mode)."""
    from .mavlink_link import mavutil
    mmap = mavutil().mavlink.mavlink_map
    crc, names, ids = {}, {}, {}
    for msgid, cls in mmap.items():
        crc[msgid] = cls.crc_extra
        names[msgid] = cls.msgname
        offset = _field_offset(cls, "id")
        if offset is not None:
            ids[msgid] = offset
    return Dialect(crc, names, ids)


def _field_offset(cls: Any, name: str) -> int | None:
    """Byte offset of a uint8 field in the wire payload of a pymavlink message class."""
    if name not in cls.ordered_fieldnames or cls.fieldtypes[cls.fieldnames.index(name)] != "uint8_t":
        return None
    tokens = re.findall(r"(\d*)([a-zA-Z?])", cls.unpacker.format.lstrip("<"))
    offset = 0
    for field, (count, code) in zip(cls.ordered_fieldnames, tokens):
        if field == name:
            return offset
        offset += struct.calcsize(f"<{count}{code}")
    return None


def packet_length(buf: bytes | memoryview, i: int) -> int | None:
    """Length of the packet starting at ``buf[i]``: None if no packet starts there,
    -1 when the header itself is cut off."""
    magic = buf[i]
    if magic == MAGIC_V2:
        if i + 3 > len(buf):
            return -1
        return 12 + buf[i + 1] + (SIGNATURE_LEN if buf[i + 2] & 0x01 else 0)
    if magic == MAGIC_V1:
        if i + 2 > len(buf):
            return -1
        return 8 + buf[i + 1]
    return None


def _msgid(pkt: bytes) -> int:
    if pkt[0] == MAGIC_V2:
        return pkt[7] | (pkt[8] << 8) | (pkt[9] << 16)
    return pkt[5]


def checksum_ok(arr: np.ndarray, i: int, pkt: bytes) -> bool:
    """Whether packet ``pkt``, found at ``arr[i]`` (the buffer as uint8), has the right
    checksum for the dialect (False for a message id it does not know)."""
    return _checksum_ok(arr, i, pkt, dialect())


def _checksum_ok(arr: np.ndarray, i: int, pkt: bytes, tables: Dialect) -> bool:
    extra = tables.crc_extra.get(_msgid(pkt))
    if extra is None:
        return False  # an id this dialect does not know: cannot be checked
    v2 = pkt[0] == MAGIC_V2
    body = (10 if v2 else 6) + pkt[1]
    expected = pkt[body] | (pkt[body + 1] << 8)
    return bool(crc_ok(arr, i + 1, i + body, extra, expected))


@dataclass
class SplitResult:
    """Packets of one buffer and what could not be used (counted as decode errors, once
    per damaged stretch: the bytes after a bad packet are part of the same damage)."""

    packets: list[bytes]
    bad_crc: int = 0    # checksum wrong, or a message id the dialect does not know
    garbage: int = 0    # runs of bytes that do not start a packet
    truncated: int = 0  # a packet cut off at the end of the buffer


def split_packets(data: bytes, check_crc: bool = True) -> SplitResult:
    """Every packet in ``data`` (one UDP datagram, or a stream chunk known to be whole).

    Bytes that start no packet are skipped to the next magic byte; a packet whose CRC
    fails (or whose id is unknown), or that is longer than what is left (truncated),
    is skipped by one byte: its magic may have been noise, and a whole packet may
    follow.
    """
    out = SplitResult([])
    n = len(data)
    if not n:
        return out
    tables = dialect() if check_crc else None
    arr = np.frombuffer(data, np.uint8) if check_crc else None
    i = 0
    damaged = False  # in bytes after a problem: counted once, until the next good packet
    while i < n:
        length = packet_length(data, i)
        if length is None:
            out.garbage += not damaged
            damaged = True
            i += 1
            continue
        if length < 0 or i + length > n:  # cut short, or a length byte that is noise
            out.truncated += not damaged
            damaged = True
            i += 1
            continue
        pkt = data[i:i + length]
        if check_crc and not _checksum_ok(arr, i, pkt, tables):
            out.bad_crc += not damaged
            damaged = True
            i += 1
            continue
        damaged = False
        out.packets.append(pkt)
        i += length
    return out


def packet_header(pkt: bytes) -> tuple[int, int, int]:
    """(sysid, compid, msgid) of a packet."""
    if pkt[0] == MAGIC_V2:
        return pkt[5], pkt[6], _msgid(pkt)
    return pkt[3], pkt[4], pkt[5]


def packet_frame(t_us: int, pkt: bytes) -> RawFrame:
    """The RawFrame of one packet received (or logged) at ``t_us`` UNIX microseconds."""
    sysid, compid, msgid = packet_header(pkt)
    t = clock.seconds(t_us)
    return RawFrame(t=t, t_recv=t, transport="mavlink", channel=msgid, data=bytes(pkt),
                    device=f"sys{sysid}/comp{compid}")


def packet_health_key(pkt: bytes) -> str:
    """``sys<s>/comp<c>/<MSGNAME>``, plus ``/<id>`` for messages with a uint8 ``id``
    field (HIGHRES_IMU of the left and right foot of one system are separate devices)."""
    sysid, compid, msgid = packet_header(pkt)
    tables = dialect()
    key = f"sys{sysid}/comp{compid}/{tables.names.get(msgid, msgid)}"
    offset = tables.id_offset.get(msgid)
    if offset is None:
        return key
    start = 10 if pkt[0] == MAGIC_V2 else 6
    # MAVLink 2 drops trailing zero bytes of the payload: a missing byte is 0
    return f"{key}/{pkt[start + offset] if offset < pkt[1] else 0}"
