"""Comma-separated ASCII device lines with an optional NMEA-style ``*HH`` checksum.

The RFID reader and the UWB ranging tag both speak this dialect over serial or UDP:
``KIND,field,field,...*HH`` where ``HH`` (hex, optional) is the XOR of every byte
before the ``*``. This module frames and checks such lines; each codec
(``uwb_lines``, ``rfid_lines``, ``baro_lines``, all :class:`CheckedLinesCodec`) parses
its own fields.
"""
from __future__ import annotations

import re
from abc import abstractmethod
from collections.abc import Iterable, Mapping
from functools import reduce
from operator import xor
from typing import Any, ClassVar

from ..contract.params import param
from ..messages import RawFrame
from .base import Codec, EncodedFrame, FrameError

__all__ = ["NAME", "CheckedLineOptions", "CheckedLinesCodec", "checksum", "encode_fields",
           "decode_fields", "decode_line"]

#: A device, reader, tag or anchor name: no commas, spaces or checksum markers.
NAME = re.compile(r"^[A-Za-z0-9_.:/-]+$")


class CheckedLineOptions(Codec.Options):
    """Options of a checked-line codec."""

    checksum: bool = param(True)
    """encoding appends the *HH checksum"""


def checksum(body: bytes) -> int:
    """The XOR of all bytes of ``body`` (the NMEA 0183 checksum)."""
    return reduce(xor, body, 0)


def encode_fields(fields: list[str], with_checksum: bool = True) -> bytes:
    """The line (no terminator) for ``fields``, with its ``*HH`` checksum if asked."""
    body = ",".join(fields).encode("ascii")
    return body + (b"*%02X" % checksum(body) if with_checksum else b"")


def decode_fields(data: bytes, kinds: tuple[str, ...]) -> list[str] | None:
    """The fields of a line whose first field is one of ``kinds``; None for other lines.

    A ``*HH`` suffix, when present, must match (else :class:`FrameError`
    ``checksum_errors``); bytes outside ASCII raise :class:`FrameError` ``bad_frames``.
    """
    try:
        text = bytes(data).decode("ascii").strip()
    except UnicodeDecodeError:
        raise FrameError("bad_frames", "line is not ASCII") from None
    if text.split(",", 1)[0] not in kinds:
        return None
    if "*" in text:
        body, _, cs = text.rpartition("*")
        try:
            ok = int(cs, 16) == checksum(body.encode("ascii"))
        except ValueError:
            ok = False
        if not ok:
            raise FrameError("checksum_errors", f"checksum mismatch: {text!r}")
        text = body
    return text.split(",")


def decode_line(data: bytes, field_counts: Mapping[str, tuple[int, ...]]
                ) -> tuple[list[str], str] | None:
    """(fields, the line's text without checksum) of a line whose first field is a kind
    of ``field_counts`` (kind -> the numbers of fields, kind included, a line of it may
    have); None for other lines. As :func:`decode_fields`, and a line with another
    number of fields raises :class:`FrameError` ``bad_frames``.
    """
    parts = decode_fields(data, tuple(field_counts))
    if parts is None:
        return None
    text = ",".join(parts)
    if len(parts) not in field_counts[parts[0]]:
        allowed = " or ".join(str(n) for n in field_counts[parts[0]])
        raise FrameError("bad_frames", f"{parts[0]} line has {len(parts)} fields, not "
                         f"{allowed}: {text!r}")
    return parts, text


class CheckedLinesCodec(Codec):
    """A codec of checked lines, one record a line: ``KIND,field,...[*HH]``.

    A subclass gives :attr:`field_counts` (its kinds -> the numbers of fields a line of
    each may have, kind included), :meth:`parse` (a line's fields -> its record) and
    :meth:`line_fields` (a record -> its line's fields). Decoding: lines of other kinds
    are not ours (None); a wrong checksum raises :class:`FrameError`
    ``checksum_errors``, a wrong number of fields ``bad_frames``. Encoding: one line per
    record (no terminator), with the checksum when the ``checksum`` option says so.
    """

    transport = "lines"
    Options = CheckedLineOptions
    field_counts: ClassVar[Mapping[str, tuple[int, ...]]] = {}

    def decode(self, frame: RawFrame) -> list[Any] | None:
        line = decode_line(frame.data, self.field_counts)
        if line is None:
            return None
        parts, text = line
        return [self.parse(frame.t, parts, text)]

    def encode(self, records: Iterable[Any], *, address: str = "") -> list[EncodedFrame]:
        return [EncodedFrame(r.t, "", encode_fields(self.line_fields(r), self.options.checksum))
                for r in records]

    @abstractmethod
    def parse(self, t: float, parts: list[str], text: str) -> Any:
        """The record of a line received at ``t`` [s] whose fields are ``parts`` (the
        number checked) and whose text is ``text`` (for errors); raises
        :class:`FrameError` ``bad_frames`` for a field that does not parse or is out of
        range."""

    @abstractmethod
    def line_fields(self, record: Any) -> list[str]:
        """The fields of the line of ``record``, kind first."""
