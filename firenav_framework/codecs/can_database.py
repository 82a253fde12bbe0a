"""DBC files: the one loader every CAN codec uses, and the layouts that ship with firenav.

A DBC file is the single source of truth of a CAN protocol: frame ids, node count,
signal scales and ranges. Codecs read it with cantools for both directions and state
which messages and signals they need (:class:`MessageSpec`); a file that lacks them is
refused when it is loaded, naming the file and what is missing, so a wrong ``dbc:``
option fails before any frame arrives. Shipped layouts live in ``codecs/dbc/``.
:class:`DbcCodec` is the base of the codecs whose layout a DBC file owns: the ``dbc``
option and its loading are there once.
"""
from __future__ import annotations

import functools
import importlib.resources
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

from ..contract.params import Params, param
from .base import Codec

__all__ = ["MessageSpec", "DbcCodec", "load_dbc", "shipped_dbc"]


@dataclass(frozen=True)
class MessageSpec:
    """Messages a codec needs: names matching ``pattern`` (a regular expression, whole
    name), at least one of them, each with every signal in ``signals``. ``label`` names
    them in errors (``IMU<n>_ACCEL``)."""

    label: str
    pattern: str
    signals: tuple[str, ...]


def shipped_dbc(name: str) -> Any:
    """The path (a Traversable) of a DBC file shipped in ``codecs/dbc/``."""
    return importlib.resources.files(__package__).joinpath("dbc", name)


@functools.lru_cache(maxsize=16)
def load_dbc(path: str | None, *, shipped: str, needs: tuple[MessageSpec, ...],
             doc: str) -> Any:
    """The cantools database of ``path`` (None: the shipped file ``shipped``), checked.

    Raises ``ValueError`` naming the file when a message of ``needs`` is missing or
    lacks a signal (``doc`` is the format page the message points to), and what
    cantools or the file system raise for a file that cannot be read.
    """
    import cantools

    if path is None:
        with importlib.resources.as_file(shipped_dbc(shipped)) as p:
            db = cantools.database.load_file(str(p))
        where = f"the shipped {shipped}"
    else:
        db = cantools.database.load_file(str(Path(path)))
        where = str(path)
    for spec in needs:
        pattern = re.compile(spec.pattern)
        found = [m for m in db.messages if pattern.fullmatch(m.name)]
        if not found:
            raise ValueError(f"{where}: no {spec.label} message (see {doc})")
        for msg in found:
            names = {s.name for s in msg.signals}
            missing = [s for s in spec.signals if s not in names]
            if missing:
                raise ValueError(f"{where}: message {msg.name} lacks signals "
                                 f"{', '.join(missing)}")
    return db


class DbcCodec(Codec):
    """A CAN codec whose layout a DBC file owns (ids, scales, ranges).

    The ``dbc`` option names the file, relative to the pipeline file; by default the
    codec's shipped layout :attr:`dbc_shipped` (in ``codecs/dbc/``). It is loaded and
    checked against :attr:`dbc_needs` once, when the codec is made (a wrong file fails
    then, naming it and pointing to the format page :attr:`dbc_doc`), as the cantools
    database :attr:`db`.
    """

    #: file name of the shipped layout in ``codecs/dbc/``
    dbc_shipped: ClassVar[str] = ""
    #: the messages and signals the codec reads and writes
    dbc_needs: ClassVar[tuple[MessageSpec, ...]] = ()
    #: the format page that documents the layout (``docs/formats/...``)
    dbc_doc: ClassVar[str] = ""

    class Options(Codec.Options):
        dbc: str | None = param(None)
        """DBC file of the layout, relative to the pipeline file (default: the layout shipped with
        the codec)"""

    def __init__(self, options: Params | dict[str, Any] | None = None, **kw: Any):
        super().__init__(options, **kw)
        dbc = self.options.dbc
        self.db = load_dbc(None if dbc is None else str(self.resolve(dbc)),
                           shipped=self.dbc_shipped, needs=self.dbc_needs,
                           doc=self.dbc_doc)
