"""Extension template for a firenav CODEC: one wire protocol, both directions.

How to use it:

1. Copy this file into your package and rename the class after the protocol; work
   through the ``TODO`` markers.
2. Register it under the codec entry-point group in your ``pyproject.toml``::

       [project.entry-points."firenav.codecs"]
       my_range_line = "acme_firenav.codec:MyRangeLineCodec"

   Sensors (and the player and simulator) then find it by name:
   ``firenav_framework.codecs.get_codec("my_range_line")``.
3. Test it with ``firenav_framework.testing.check_codec(MyRangeLineCodec,
   records=[...], address="tag7")``.

As it is, the class is a working example: a text line ``MYRNG,<anchor>,<mm>*HH`` (a
range in millimetres, ``HH`` the XOR of the characters between ``M`` and ``*`` in hex)
per UWB ranging report. It passes ``check_codec``.

The contract (``firenav_framework/codecs/base.py``):

* ``name``, ``transport`` (``"can"``, ``"mavlink"``, ``"lines"`` (serial and UDP text lines)),
  ``record`` (what ``decode`` returns a list of) and ``Options`` (its settings).
* One instance per input: ``decode(frame)`` returns the records a frame completes
  (often none), ``None`` for a frame of another protocol, and raises ``FrameError``
  for a frame of this protocol that cannot be decoded; nothing else, ever.
* Records name their device ``<link>/<address>`` (the link is the frame's ``device``);
  ``encode(records, address=...)`` sends as that address.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import reduce

from firenav_framework import Params, RawFrame, param
from firenav_framework.codecs import Codec, EncodedFrame, FrameError

PREFIX = b"MYRNG,"


@dataclass(frozen=True)
class RangeReport:
    """One ranging report: time [s], the reporting device, the anchor and the range [m]."""

    t: float
    device: str
    anchor: str
    range_m: float


def _checksum(body: bytes) -> int:
    return reduce(lambda a, b: a ^ b, body, 0)


class MyRangeLineCodec(Codec):
    """MYRNG text lines: one UWB range per line, in millimetres, XOR-checked."""

    # TODO: the registry name, the transport and the record type.
    name = "my_range_line"
    transport = "lines"
    record = RangeReport

    class Options(Params):
        # TODO: the protocol's settings.
        max_range: float = param(300.0, unit="m", gt=0)
        """longer ranges are not this protocol's (a corrupt line)"""

    def decode(self, frame: RawFrame) -> list[RangeReport] | None:
        # TODO: your protocol. None: not ours; FrameError: ours but broken.
        data = bytes(frame.data).strip()
        if not data.startswith(PREFIX):
            return None
        body, star, check = data.partition(b"*")
        if not star or len(check) != 2:
            raise FrameError("bad_lines", f"no '*HH' checksum in {data[:40]!r}")
        try:
            sent = int(check, 16)
        except ValueError:
            raise FrameError("bad_lines", f"checksum {check!r} is not hex") from None
        if sent != _checksum(body[1:]):
            raise FrameError("bad_checksums", f"checksum mismatch in {data[:40]!r}")
        try:
            fields = body[len(PREFIX):].decode("ascii").split(",")
            anchor, mm = fields if len(fields) == 2 else ("", "x")
            range_m = int(mm) / 1000.0
        except (ValueError, UnicodeDecodeError):
            raise FrameError("bad_lines", f"not MYRNG,<anchor>,<mm>: {data[:40]!r}") from None
        if not anchor or not 0.0 <= range_m <= self.options.max_range:
            raise FrameError("bad_lines", f"no anchor or an impossible range in {data[:40]!r}")
        return [RangeReport(frame.t, f"{frame.device}/{frame.channel or 'tag'}", anchor, range_m)]

    def encode(self, records: list[RangeReport], *, address: str = "") -> list[EncodedFrame]:
        # TODO: the inverse of decode (a decode-only protocol leaves this out).
        out = []
        for r in records:
            body = PREFIX + f"{r.anchor},{round(r.range_m * 1000.0)}".encode("ascii")
            line = body + f"*{_checksum(body[1:]):02X}".encode("ascii")
            out.append(EncodedFrame(r.t, address, line))
        return out
