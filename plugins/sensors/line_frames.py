"""Decoding a RawFrame of text lines with the sensor's codec for its transport."""
from __future__ import annotations

from typing import Callable

from firenav_framework import RawFrame
from firenav_framework.codecs.selection import TransportCodecs

__all__ = ["decode_lines"]


def decode_lines(codecs: TransportCodecs, frame: RawFrame,
                 count: Callable[[str], None]) -> list | None:
    """The records of ``frame`` as its transport's codec decodes them, or None, counted:
    ``frames_not_lines`` when the sensor decodes no frames of that transport,
    ``other_lines`` when the frame holds none of the codec's records. A broken line
    raises the codec's :class:`~firenav_framework.codecs.FrameError`."""
    codec = codecs.get(frame.transport)
    if codec is None:
        count("frames_not_lines")
        return None
    records = codec.decode(frame)
    if records is None:
        count("other_lines")
    return records
