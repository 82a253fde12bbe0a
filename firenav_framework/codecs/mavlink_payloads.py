"""MAVLink packets checked and read in numba: the CRC, and HIGHRES_IMU many at a time.

A live MAVLink link delivers thousands of IMU packets per second; building a pymavlink
message object per packet costs more than everything else the kit does with it.
:func:`unpack_highres` checks a batch of HIGHRES_IMU packets in one numba call (magic
byte, length, message id, CRC-16/MCRF4XX with the message's ``crc_extra``) and reads
their fields into one row each of a float array. MAVLink 2 drops trailing zero bytes of
a payload; they are read as zeros, as pymavlink does. MAVLink 1 packets (magic ``0xFE``) are read too; a
MAVLink 2 signature (13 bytes, incompatibility flag 0x01) is allowed and not checked,
as pymavlink does without a signing key.
"""
from __future__ import annotations

from collections.abc import Sequence
import numpy as np
from numba import njit

__all__ = ["crc_ok", "unpack_highres", "PACKET_PROBLEMS", "HIGHRES_ID"]

MAGIC_V1, MAGIC_V2 = 0xFE, 0xFD
SIGNATURE_LEN = 13
HIGHRES_ID = 105
HIGHRES_CRC_EXTRA = 93
#: HIGHRES_IMU's full payload (MAVLink orders fields by size): time_usec uint64 at 0;
#: 13 float32 from 8 (xacc, yacc, zacc, xgyro, ygyro, zgyro, xmag, ymag, zmag, then
#: pressures and temperature); fields_updated uint16 at 60; id uint8 at 62.
HIGHRES_SIZE = 63

#: Status codes of :func:`unpack_payloads` (0: good) and what each means.
PACKET_PROBLEMS = {1: "not a whole MAVLink packet", 2: "bad CRC",
                   3: "another message id", 4: "payload longer than the message"}


@njit(cache=True, nogil=True)
def crc_ok(buf: np.ndarray, start: int, end: int, extra: int, expected: int) -> bool:
    """CRC-16/MCRF4XX of ``buf[start:end]`` then ``extra`` equals ``expected``."""
    crc = 0xFFFF
    for i in range(start, end + 1):
        b = (buf[i] if i < end else extra) ^ (crc & 0xFF)
        b = (b ^ (b << 4)) & 0xFF
        crc = ((crc >> 8) ^ (b << 8) ^ (b << 3) ^ (b >> 4)) & 0xFFFF
    return crc == expected


@njit(cache=True, nogil=True)
def _check(buf: np.ndarray, s: int, size: int, msgid: int, extra: int, width: int
           ) -> tuple[int, int, int]:
    """(status, payload start, payload length) of the packet ``buf[s:s + size]``."""
    if size < 8:
        return 1, 0, 0
    n = buf[s + 1]
    if buf[s] == MAGIC_V2:
        head = 10
        total = 12 + n + (SIGNATURE_LEN if buf[s + 2] & 0x01 else 0)
        mid = buf[s + 7] | (buf[s + 8] << 8) | (buf[s + 9] << 16) if size >= 12 else -1
    elif buf[s] == MAGIC_V1:
        head = 6
        total = 8 + n
        mid = buf[s + 5]
    else:
        return 1, 0, 0
    if total != size:
        return 1, 0, 0
    if mid != msgid:
        return 3, 0, 0
    if n > width:
        return 4, 0, 0
    if not crc_ok(buf, s + 1, s + head + n, extra,
                  buf[s + head + n] | (buf[s + head + n + 1] << 8)):
        return 2, 0, 0
    return 0, s + head, n


@njit(cache=True, nogil=True)
def _highres(buf: np.ndarray, starts: np.ndarray, out: np.ndarray) -> None:
    scratch = np.zeros(HIGHRES_SIZE + 1, np.uint8)
    for k in range(len(starts) - 1):
        s = starts[k]
        status, p, n = _check(buf, s, starts[k + 1] - s, HIGHRES_ID, HIGHRES_CRC_EXTRA,
                              HIGHRES_SIZE)
        out[k, 13] = status
        if status:
            continue
        scratch[:] = 0
        scratch[:n] = buf[p:p + n]
        out[k, 0] = scratch[0:8].view(np.uint64)[0] * 1e-6
        out[k, 1:10] = scratch[8:44].view(np.float32)
        out[k, 10] = scratch[60] | (scratch[61] << 8)
        v1 = buf[s] == MAGIC_V1
        out[k, 11] = (buf[s + 3] if v1 else buf[s + 5]) << 16 | (
            buf[s + 4] if v1 else buf[s + 6]) << 8 | scratch[62]
        out[k, 12] = 0


def unpack_highres(packets: Sequence[bytes]) -> np.ndarray:
    """HIGHRES_IMU ``packets`` (one complete packet each) checked and read: row k is
    time_usec * 1e-6 [s], xacc..zacc, xgyro..zgyro, xmag..zmag (as sent), fields_updated,
    sysid << 16 | compid << 8 | id, 0, status (0 good, else a key of
    :data:`PACKET_PROBLEMS`; the other columns of a bad packet are 0)."""
    n = len(packets)
    starts = np.zeros(n + 1, np.int64)
    starts[1:] = list(map(len, packets))
    np.cumsum(starts, out=starts)
    out = np.zeros((n, 14))
    _highres(np.frombuffer(b"".join(packets), np.uint8), starts, out)
    return out
