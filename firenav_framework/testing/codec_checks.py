"""Conformance checks of a wire codec (:class:`~firenav_framework.codecs.Codec`).

=================  ===========================================================================
check              what it asserts
=================  ===========================================================================
``class``          a concrete Codec subclass with a name, a transport, a record type, a
                   docstring summary and described ``Options``
``round_trip``     (given what ``encode`` takes) the frames decode, without a FrameError,
                   to records of the declared type; when ``encode`` takes a list of those
                   records, the decoded ones encode to the very same frames
``bad_frames``     truncated, empty, garbled and foreign frames are answered with records,
                   None or :class:`~firenav_framework.codecs.FrameError`, nothing else
``deterministic``  two fresh codecs decode the same frames to the same records
=================  ===========================================================================
"""
from __future__ import annotations

import dataclasses
import inspect
from collections.abc import Callable, Iterable, Sequence
from typing import Any

import numpy as np

from ..codecs import Codec, FrameError, to_raw_frames
from ..messages import RawFrame
from .checks import (CheckFailed, NotApplicable, parameter_problems, raise_problems, registrar,
                     run_registered)

__all__ = ["CODEC_CHECKS", "CodecCase", "check_codec", "run_codec_checks"]

#: The link transports foreign frames are made up for.
TRANSPORTS = ("can", "mavlink", "serial", "udp")


@dataclasses.dataclass
class CodecCase:
    """A codec class, its options, what its ``encode`` takes (``records``, sent as device
    ``address``) and sample frames to decode."""

    cls: type[Codec]
    options: dict | None = None
    records: Any = None
    address: str = ""
    frames: list[RawFrame] = dataclasses.field(default_factory=list)

    def codec(self) -> Codec:
        return self.cls(self.options)

    def sample_frames(self) -> list[RawFrame]:
        """The given frames, else those the sample records encode to."""
        if self.frames or self.records is None:
            return list(self.frames)
        return _encode(self.codec(), self.records, self.address)

    def symmetric(self) -> bool:
        """Whether ``encode`` takes a list of the very records ``decode`` returns."""
        return isinstance(self.records, list) and bool(self.records) and all(
            isinstance(r, self.cls.record) for r in self.records)


def _encode(codec: Codec, records: Any, address: str) -> list[RawFrame]:
    encoded = codec.encode(records, address=address)
    return to_raw_frames(encoded, transport=codec.transport, device="link")


def _decode_all(codec: Codec, frames: Iterable[RawFrame]) -> list[Any]:
    """Every record the frames decode to, a FrameError as ``("FrameError", code)``."""
    out: list[Any] = []
    for frame in frames:
        try:
            out.extend(codec.decode(frame) or ())
        except FrameError as exc:
            out.append(("FrameError", exc.code))
    codec.finish()
    return out


#: The codec checks in the order they run: name -> check.
CODEC_CHECKS: dict[str, Callable[[CodecCase], None]] = {}
_codec_check = registrar(CODEC_CHECKS)


@_codec_check("class")
def check_codec_class(case: CodecCase) -> None:
    """The class is a well-formed codec."""
    cls, problems = case.cls, []
    if not (isinstance(cls, type) and issubclass(cls, Codec)):
        raise CheckFailed(f"{cls!r} is not a Codec subclass")
    if inspect.isabstract(cls):
        missing = ", ".join(sorted(cls.__abstractmethods__))
        raise CheckFailed(f"{cls.__name__} does not implement {missing} (required of a codec)")
    if not cls.name or not cls.name.replace("_", "").replace("-", "").isalnum():
        problems.append("needs a `name` made of letters, digits, '_' or '-'")
    if not (isinstance(cls.transport, str) and cls.transport):
        problems.append("needs a `transport`: the links it serves (can, mavlink, ...)")
    if not isinstance(cls.record, type) or cls.record is object:
        problems.append("`record` must name the type decode() returns a list of")
    if not cls.summary():
        problems.append("needs a docstring: its first line is the summary")
    problems += [f"Options.{p}" for p in parameter_problems(cls.Options)]
    raise_problems(problems, f"codec {cls.__name__}")


@_codec_check("round_trip")
def check_codec_round_trip(case: CodecCase) -> None:
    """Encoded records decode to records that encode to the same frames."""
    if case.records is None:
        raise NotApplicable("no sample records")
    codec = case.codec()
    try:
        frames = _encode(codec, case.records, case.address)
    except NotImplementedError:
        raise NotApplicable(f"codec {case.cls.name!r} only decodes") from None
    decoded = _decode_all(case.codec(), frames)
    refused = [r[1] for r in decoded if isinstance(r, tuple) and r[:1] == ("FrameError",)]
    problems = []
    if refused:
        problems.append(f"decode() refused its own frames: {refused[0]}")
    elif not decoded:
        problems.append(f"the {len(frames)} frames encoded from the sample decode to nothing")
    elif not all(isinstance(r, case.cls.record) for r in decoded):
        problems.append(f"decode() returned {sorted({type(r).__name__ for r in decoded})}, "
                        f"declared record {case.cls.record.__name__}")
    elif case.symmetric():
        again = _encode(case.codec(), decoded, case.address)
        if [(f.channel, f.data) for f in again] != [(f.channel, f.data) for f in frames]:
            problems.append("records decoded from the encoded frames encode to other frames")
    raise_problems(problems, f"codec {case.cls.__name__}: round trip")


def _damaged(frames: Sequence[RawFrame], rng: np.random.Generator) -> list[tuple[str, RawFrame]]:
    out = []
    for f in frames[:8]:
        data = bytes(f.data)
        garbled = bytes(rng.integers(0, 256, len(data), dtype=np.uint8)) if data else b"\xff"
        for what, bad in (("truncated", data[: len(data) // 2]), ("empty", b""),
                          ("garbled", garbled), ("extended", data + data)):
            out.append((f"{what} frame on channel {f.channel!r}",
                        dataclasses.replace(f, data=bad)))
    foreign = {"can": 0x7AB, "mavlink": 30001}
    for transport in TRANSPORTS:
        channel = foreign.get(transport, "")
        out.append((f"foreign {transport} frame", RawFrame(
            t=1.0, device="link", transport=transport, channel=channel,
            data=bytes(rng.integers(0, 256, 12, dtype=np.uint8)))))
    return out


@_codec_check("bad_frames")
def check_codec_bad_frames(case: CodecCase) -> None:
    """Damaged and foreign frames give records, None or FrameError, never another error."""
    rng = np.random.default_rng(13)
    problems = []
    for what, frame in _damaged(case.sample_frames(), rng):
        codec = case.codec()
        try:
            got = codec.decode(frame)
            codec.finish()
        except FrameError:
            continue
        except Exception as exc:
            problems.append(f"{what}: {type(exc).__name__} escaped: {exc} (raise FrameError "
                            f"for a frame of this protocol that cannot be decoded)")
            continue
        if got is not None and not isinstance(got, list):
            problems.append(f"{what}: decode() returned {type(got).__name__}, not a list or None")
    raise_problems(problems, f"codec {case.cls.__name__}: bad frames")


@_codec_check("deterministic")
def check_codec_deterministic(case: CodecCase) -> None:
    """Two fresh codecs decode the same frames to the same records."""
    frames = case.sample_frames()
    if not frames:
        raise NotApplicable("no sample records or frames")
    a, b = _decode_all(case.codec(), frames), _decode_all(case.codec(), frames)
    if repr(a) != repr(b):
        raise CheckFailed(f"codec {case.cls.__name__}: the same frames decode to different "
                          f"records in two fresh codecs")


def run_codec_checks(case: CodecCase, checks: Iterable[str] | None = None,
                     exclude: Iterable[str] = ()) -> dict[str, Any]:
    """Run the codec checks on ``case``: name -> "passed", "n/a: <why>" or the exception."""
    return run_registered(CODEC_CHECKS, case, checks, exclude)


def check_codec(cls: type[Codec], options: dict | None = None, *, records: Any = None,
                address: str = "", frames: Iterable[RawFrame] = ()) -> dict[str, Any]:
    """Assert that ``cls`` conforms to the codec contract; return every check's outcome.

    ``records`` is sample input of ``encode`` (a list of records, or what the protocol
    encodes, e.g. an ImuBlock), sent as device ``address``; a codec that can encode
    should be given some, the round trip needs them. ``frames`` are sample frames to
    decode (default: those the records encode to). Raises
    :class:`~firenav_framework.testing.ConformanceError` listing every failed check.
    """
    from .suite import ConformanceError

    case = CodecCase(cls, options, records, address, list(frames))
    results = run_codec_checks(case)
    if any(isinstance(v, BaseException) for v in results.values()):
        raise ConformanceError(cls, results)
    return results
