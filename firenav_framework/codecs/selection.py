"""How a sensor chooses its codecs: a parameter group naming one codec per link transport.

A sensor that reads :class:`~firenav_framework.messages.RawFrame` declares a
:class:`CodecSelection` subclass as a nested parameter group, with the record type it
understands and its default codecs (and more fields of its own)::

    class Frames(CodecSelection):
        record: ClassVar[type] = ImuSample
        codecs: dict[str, str] = param({"can": "can_imu", "serial": "imu_lines"}, ...)

and in YAML a user may swap in any registered codec, built in or a vendor's::

    frames: {codecs: {can: acme_can_imu}, codec_options: {acme_can_imu: {nodes: 4}}}

Validation (before anything runs) checks that each codec is registered, serves its
transport and decodes the sensor's record type, and checks each codec's options
against its ``Options`` model. At run time :class:`TransportCodecs` holds one codec
instance per name and hands out the one of a frame's transport.
"""
from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any, ClassVar

from pydantic import ValidationError, ValidationInfo, field_validator

from ..contract.params import Params, param
from ..messages import RawFrame
from . import UnknownCodec, get_codec
from .base import Codec

__all__ = ["CodecSelection", "TransportCodecs"]


class CodecSelection(Params):
    """Which registered codec decodes the frames of each link transport, and its options."""

    #: The record type the sensor reads; every chosen codec must decode it (or a subclass).
    record: ClassVar[type] = object

    codecs: dict[str, str] = param({})
    """link transport (RawFrame.transport: can, mavlink, serial, udp ...) -> registered codec name;
    frames of other transports are not decoded"""
    codec_options: dict[str, dict[str, Any]] = param({})
    """codec name -> its options (docs/formats/codecs.md)"""

    @field_validator("codecs")
    @classmethod
    def _codecs_fit(cls, codecs: dict[str, str]) -> dict[str, str]:
        for transport, name in codecs.items():
            try:
                codec = get_codec(name)
            except UnknownCodec as exc:
                raise ValueError(f"{transport}: {exc}") from None
            if not codec.serves(transport):
                raise ValueError(f"{transport}: codec {name!r} reads {codec.transport!r} "
                                 f"frames, not {transport!r}")
            if not issubclass(codec.record, cls.record):
                raise ValueError(f"{transport}: codec {name!r} decodes "
                                 f"{codec.record.__name__} records; this sensor reads "
                                 f"{cls.record.__name__}")
        return codecs

    @field_validator("codec_options")
    @classmethod
    def _options_fit(cls, options: dict[str, dict[str, Any]],
                     info: ValidationInfo) -> dict[str, dict[str, Any]]:
        codecs = info.data.get("codecs")
        if codecs is None:   # already refused above
            return options
        for name, values in options.items():
            if name not in codecs.values():
                raise ValueError(f"options for {name!r}, which no transport uses (codecs: "
                                 f"{', '.join(sorted(set(codecs.values()))) or 'none'})")
            try:
                get_codec(name).Options.model_validate(values)
            except ValidationError as exc:
                problems = "; ".join(f"{'.'.join(map(str, e['loc'])) or name}: {e['msg']}"
                                     for e in exc.errors())
                raise ValueError(f"{name}: {problems}") from None
        return options


class TransportCodecs:
    """A sensor's codec instances: one per chosen codec, looked up by frame transport.

    ``count`` and ``resolve`` are handed to every codec (see
    :class:`~firenav_framework.codecs.base.Codec`).
    """

    def __init__(self, selection: CodecSelection, *, count: Callable[[str, int], None],
                 resolve: Callable[[str], Path] = Path):
        self.selection = selection
        self._count, self._resolve = count, resolve
        self._made: dict[str, Codec] = {}
        self._by_transport: dict[str, Codec | None] = {}
        for name in selection.codec_options:   # configured: a bad file fails at set-up
            self._make(name)

    def _make(self, name: str) -> Codec:
        codec = self._made.get(name)
        if codec is None:
            codec = self._made[name] = get_codec(name)(
                self.selection.codec_options.get(name), count=self._count,
                resolve=self._resolve)
        return codec

    def get(self, transport: str) -> Codec | None:
        """The codec of frames of ``transport`` (None: this sensor does not decode them).
        A codec without options is made at the first frame of its transport, so a
        pipeline of recorded blocks never loads a DBC or a MAVLink dialect."""
        codec = self._by_transport.get(transport, False)
        if codec is False:
            name = self.selection.codecs.get(transport)
            codec = self._by_transport[transport] = None if name is None else self._make(name)
        return codec

    def decode(self, frame: RawFrame, *, no_codec: str = "frames_not_lines",
               other: str = "other_lines") -> list | None:
        """The records of ``frame`` as its transport's codec decodes them, or None, counted:
        ``no_codec`` when this sensor decodes no frames of that transport, ``other`` when
        the frame holds none of the codec's records. A broken frame raises the codec's
        :class:`~firenav_framework.codecs.FrameError`."""
        codec = self.get(frame.transport)
        if codec is None:
            self._count(no_codec, 1)
            return None
        records = codec.decode(frame)
        if records is None:
            self._count(other, 1)
        return records

    @property
    def codecs(self) -> list[Codec]:
        """The codecs made so far."""
        return list(self._made.values())

    def finish(self) -> None:
        """End of input for every codec made (each counts what is still incomplete)."""
        for codec in self._made.values():
            codec.finish()
