"""Wire codecs: a registered kind of their own, like python-can's interface backends.

Built-in codecs are listed in :data:`BUILTIN_CODECS` (name -> ``"module:Class"``); a
package adds more under the entry-point group ``firenav.codecs``::

    [project.entry-points."firenav.codecs"]
    acme_can_imu = "acme_firenav.codec:AcmeCanImu"

Both are imported only when a codec is asked for by name (:func:`get_codec`), so a
broken or slow codec package costs nothing to pipelines that do not use it. The
contract a codec implements is :class:`~.base.Codec`; a sensor picks its codecs with a
:class:`~.selection.CodecSelection` parameter group. The built-in protocols and their
options are listed in ``docs/formats/codecs.md``.
"""
from __future__ import annotations

import difflib
import functools
import importlib
import importlib.metadata as md

from .base import Codec, EncodedFrame, FrameError, to_raw_frames
from ..safe_import import PluginImportError, import_object

__all__ = ["Codec", "EncodedFrame", "FrameError", "to_raw_frames", "BUILTIN_CODECS",
           "CODEC_GROUP", "UnknownCodec", "get_codec", "codec_names"]

CODEC_GROUP = "firenav.codecs"

#: The codecs that ship with firenav: name -> "module:Class".
BUILTIN_CODECS: dict[str, str] = {
    "can_imu": "firenav_framework.codecs.can_imu:CanImuCodec",
    "mavlink_imu": "firenav_framework.codecs.mavlink_imu:MavlinkImuCodec",
    "imu_lines": "firenav_framework.codecs.imu_lines:ImuLinesCodec",
    "uwb_lines": "firenav_framework.codecs.uwb_lines:UwbLinesCodec",
    "uwb_can": "firenav_framework.codecs.uwb_can:UwbCanCodec",
    "rfid_lines": "firenav_framework.codecs.rfid_lines:RfidLinesCodec",
    "baro_lines": "firenav_framework.codecs.baro_lines:BaroLinesCodec",
    "breadcrumb_lines": "firenav_framework.codecs.breadcrumb_lines:BreadcrumbLinesCodec",
}


class UnknownCodec(LookupError):
    """No codec of that name is installed (or it failed to load)."""


@functools.lru_cache(maxsize=1)
def _entry_points() -> dict[str, md.EntryPoint]:
    return {ep.name: ep for ep in md.entry_points(group=CODEC_GROUP)}


def codec_names() -> list[str]:
    """Names of every codec, built in or registered (nothing is imported)."""
    return sorted(set(BUILTIN_CODECS) | set(_entry_points()))


@functools.lru_cache(maxsize=None)
def get_codec(name: str) -> type[Codec]:
    """The codec class registered as ``name`` (built-ins win over entry points).

    Raises :class:`UnknownCodec` with the closest names, or with the import error of a
    codec that failed to load.
    """
    target = BUILTIN_CODECS.get(name)
    ep = None if target is not None else _entry_points().get(name)
    if target is None and ep is None:
        close = difflib.get_close_matches(name, codec_names(), n=3, cutoff=0.5)
        hint = f"; did you mean {' or '.join(map(repr, close))}?" if close else ""
        raise UnknownCodec(f"no codec named {name!r}{hint}")
    try:
        if ep is not None:  # a vendor's: a hang or sys.exit() at import is contained too
            cls = import_object(ep.value)
        else:
            module, _, attr = target.partition(":")
            cls = getattr(importlib.import_module(module), attr)
    except PluginImportError as exc:
        raise UnknownCodec(f"codec {name!r} failed to load: {exc.detail}") from exc
    except Exception as exc:
        raise UnknownCodec(f"codec {name!r} failed to load: {type(exc).__name__}: {exc}") from exc
    if not (isinstance(cls, type) and issubclass(cls, Codec)) or cls.name != name:
        raise UnknownCodec(f"codec {name!r} does not name a Codec subclass called {name!r}")
    return cls
