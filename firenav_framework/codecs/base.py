"""The codec contract: one wire protocol of one transport, both directions.

A codec turns link frames (:class:`~firenav_framework.messages.RawFrame`: a CAN frame, a
MAVLink packet, a text line) into *records* (an IMU sample, a UWB ranging report ...) and
records back into frames. Sensors decode with codecs; the player, the simulator and the
field-kit tests encode with the same ones, so a protocol has one implementation. A vendor
adds a wire protocol by registering a codec (see :mod:`firenav_framework.codecs`), without
writing a sensor.

Contract of a :class:`Codec` subclass:

* ``name`` (registry key), ``transport`` (``"can"``, ``"mavlink"``, or ``"lines"``
  for a text-line codec, which serves the ``"serial"`` and ``"udp"`` links alike; a
  vendor transport names itself), ``record`` (the type :meth:`Codec.decode` returns a
  list of) and ``Options`` (a pydantic model of its settings: a DBC file, raw scale
  factors ...). Every record carries its time ``t`` [s]: the device's clock when the
  protocol has one, else the frame's time.
* One instance per input: decoding may keep state across frames (samples spread over
  several frames, counters that wrap), and so may encoding (sequence counters per
  address). :meth:`Codec.decode` returns the records a frame completes (often none),
  ``None`` for a frame that is not of this protocol (another device on the same bus),
  and raises :class:`FrameError` for a frame that is of this protocol but cannot be
  decoded. It never raises anything else for bad bytes.
* Losses that are not one frame's fault (a sample whose frames never all arrived) are
  counted through the ``count`` callable given at construction; file names in the
  options (a DBC) are resolved by the ``resolve`` callable (a sensor passes
  ``ctx.resolve``: relative to the pipeline file).
* Device addresses: a record that comes from an addressed device names it as
  ``<link>/<address>`` (the link is the frame's ``device``, e.g. the CAN bus;
  MAVLink addresses ``sys<s>/comp<c>/imu<i>`` are network-wide and stand alone);
  :meth:`Codec.encode` takes the address to send as, :meth:`Codec.addresses` lists
  those the protocol has (None: any) and :meth:`Codec.channels` the channels (CAN
  ids, MAVLink message ids) one address sends on.
"""
from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any, ClassVar, NamedTuple

from ..contract.params import Params
from ..messages import RawFrame

__all__ = ["Codec", "FrameError", "EncodedFrame", "Decoded", "to_raw_frames",
           "LINE_TRANSPORTS"]

#: The link transports a ``"lines"`` codec serves.
LINE_TRANSPORTS = ("serial", "udp")


class FrameError(ValueError):
    """A frame of a codec's protocol that cannot be decoded.

    ``code`` is the name it is counted under (``bad_frames``, ``unknown_can_ids`` ...).
    """

    def __init__(self, code: str, text: str):
        super().__init__(text)
        self.code = code


class EncodedFrame(NamedTuple):
    """One encoded frame: time [s], channel (CAN id, MAVLink msgid or ""), payload."""

    t: float
    channel: int | str
    data: bytes


class Decoded(NamedTuple):
    """What :meth:`Codec.decode_batch` made of a batch of frames: the ``records`` they
    completed, in frame order; ``origin``, the index in the batch of the frame that
    completed each record; the ``problems`` (index of the frame, its
    :class:`FrameError`); and how many frames were ``ignored`` (not of this protocol)."""

    records: Sequence[Any]
    origin: Sequence[int]
    problems: list[tuple[int, FrameError]]
    ignored: int


def to_raw_frames(frames: Iterable[EncodedFrame], *, transport: str, device: str,
                  t_recv: float | None = None) -> list[RawFrame]:
    """Wrap encoded frames as :class:`RawFrame` messages (``t_recv`` = ``t_recv + t``)."""
    return [RawFrame(t=f.t, device=device, transport=transport, channel=f.channel,
                     data=bytes(f.data), t_recv=None if t_recv is None else t_recv + f.t)
            for f in frames]


def _no_count(what: str, n: int = 1) -> None:
    """Default counter: nothing is recorded."""


class Codec(ABC):
    """One wire protocol of one transport (see the module docstring for the contract)."""

    name: ClassVar[str] = ""
    transport: ClassVar[str] = ""
    record: ClassVar[type] = object

    class Options(Params):
        """Settings of the protocol (none by default)."""

    def __init__(self, options: Params | dict[str, Any] | None = None, *,
                 count: Callable[[str, int], None] = _no_count,
                 resolve: Callable[[str], Path] = Path):
        if not isinstance(options, Params):
            options = self.Options.model_validate(options or {})
        self.options = options
        self.count = count
        self.resolve = resolve

    @classmethod
    def serves(cls, transport: str) -> bool:
        """Whether this codec reads frames of link ``transport`` (``RawFrame.transport``)."""
        return transport == cls.transport or (cls.transport == "lines"
                                               and transport in LINE_TRANSPORTS)

    @classmethod
    def summary(cls) -> str:
        """First line of the class docstring."""
        doc = (cls.__doc__ or "").strip()
        return doc.splitlines()[0].strip() if doc else ""

    @abstractmethod
    def decode(self, frame: RawFrame) -> list[Any] | None:
        """Records completed by ``frame``; None if it is not of this protocol.

        Raises :class:`FrameError` for a frame of this protocol that cannot be decoded.
        """

    def decode_batch(self, frames: Sequence[RawFrame]) -> Decoded:
        """:meth:`decode` of each of ``frames`` in turn, as one :class:`Decoded`.

        A codec whose protocol decodes faster many frames at a time (fixed layouts read
        with numpy) overrides this; the records and problems must be those
        :meth:`decode` gives frame by frame.
        """
        records: list[Any] = []
        origin: list[int] = []
        problems: list[tuple[int, FrameError]] = []
        ignored = 0
        for i, frame in enumerate(frames):
            try:
                out = self.decode(frame)
            except FrameError as exc:
                problems.append((i, exc))
                continue
            if out is None:
                ignored += 1
            else:
                records += out
                origin += [i] * len(out)
        return Decoded(records, origin, problems, ignored)

    def finish(self) -> None:
        """End of input: count what is still incomplete (default: nothing)."""

    def encode(self, records: Any, *, address: str = "") -> list[EncodedFrame]:
        """Frames that send ``records`` as device ``address`` (decode-only codecs raise)."""
        raise NotImplementedError(f"codec {self.name!r} cannot encode")

    def addresses(self) -> Sequence[str] | None:
        """The device addresses this protocol has (e.g. the nodes of a DBC), None: any."""
        return None

    def channels(self, address: str) -> Sequence[int | str] | None:
        """The channels frames sent as ``address`` use (CAN ids ...), None: not fixed."""
        return None
