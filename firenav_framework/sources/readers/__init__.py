"""Readers of recorded files for the ``recording`` source, chosen by file suffix.

Like python-can's ``can.LogReader``, the reader is looked up by the file's suffix
in a table. The table is merged from every module of this package, so a new
format is one new module and no existing file changes. A module declares::

    READERS = {".csv": ImuCsvReader}              # suffix (lower case, with the dot) -> reader
    FORMATS = {"imu_csv": ImuCsvReader}           # optional: names for the `format:` parameter
    PORTS = {"raw": RawFrame}                     # optional: ports its messages use, if new

A module that fails to import is logged and listed in :func:`reader_table`'s
``errors`` (and in the error for a file nobody can read); the others still load.
When two modules claim the same suffix or name, the first (modules sorted by name)
keeps it and the clash is listed as an error.

The reader contract
-------------------
A *reader* is any callable ``reader(path: Path, options: ReadOptions)``: a class or
a function (:class:`~firenav_framework.formats.base.ReadOptions` carries the agent, device, IMU block length
and a ``count`` callback).

* Calling it opens and checks the file. A file it cannot read raises
  :class:`~firenav_framework.formats.base.ReaderError` (or ``OSError``) with a message that names the file and
  what was expected; the source reports it before the run starts.
* The call returns an iterable of ``(port, message)`` pairs: ``port`` is one of
  :data:`PORTS` (``imu`` ImuBlock in the device frame, ``truth`` GroundTruth,
  ``reference`` PoseEstimate of a stored reference solution, ``raw`` RawFrame for
  link logs such as CAN or MAVLink) and each port's messages come in time order.
  Times are seconds on the recording's own clock (the source adds ``time_offset``).
* The returned object may have ``duration() -> (first, last)`` [s] for progress.
* Rows or records that cannot be read are skipped and counted with
  ``options.count(what, n)``; everything else is passed on as recorded: judging
  samples (NaN, out of range, duplicates, time going backwards) is the sensor
  plugin's job, so that it is counted in one place.

Plain array loaders for the real datasets live in
:mod:`.foot_imu_datasets` (``load_vicon_trial``, ``load_indoor_walk``).
"""
from __future__ import annotations

import functools
import importlib
import logging
import pkgutil
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

from ...messages import GroundTruth, ImuBlock, Message, PoseEstimate, RawFrame
from ...formats.base import ReaderError, ReadOptions, imu_blocks

__all__ = ["PORTS", "ReaderError", "ReadOptions", "ReaderTable", "find_reader",
           "imu_blocks", "reader_table"]

log = logging.getLogger("firenav.readers")

#: Ports every recording source offers; reader modules may add more with ``PORTS``.
PORTS: dict[str, type[Message]] = {
    "imu": ImuBlock, "truth": GroundTruth, "reference": PoseEstimate, "raw": RawFrame,
}

Reader = Callable[[Path, ReadOptions], Any]


@dataclass
class ReaderTable:
    """Readers by suffix and by format name, the ports they use, and load problems."""

    by_suffix: dict[str, Reader] = field(default_factory=dict)
    by_name: dict[str, Reader] = field(default_factory=dict)
    ports: dict[str, type[Message]] = field(default_factory=lambda: dict(PORTS))
    errors: list[str] = field(default_factory=list)

    def add_module(self, name: str, module: Any) -> None:
        for attr, table in (("READERS", self.by_suffix), ("FORMATS", self.by_name)):
            for key, reader in (getattr(module, attr, None) or {}).items():
                key = key.lower()
                if attr == "READERS" and not key.startswith("."):
                    self.errors.append(f"{name}: READERS key '{key}' is not a suffix like '.csv'")
                elif key in table:
                    self.errors.append(f"{name}: {attr} '{key}' is already taken; ignored")
                else:
                    table[key] = reader
        for port, mtype in (getattr(module, "PORTS", None) or {}).items():
            if self.ports.setdefault(port, mtype) is not mtype:
                self.errors.append(f"{name}: port '{port}' already carries "
                                   f"{self.ports[port].__name__}; ignored")


@functools.lru_cache(maxsize=1)
def reader_table() -> ReaderTable:
    """Every reader of this package's modules (loaded once, on first use)."""
    table = ReaderTable()
    for mod in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
        if mod.name.startswith("_"):
            continue
        try:
            module = importlib.import_module(f"{__name__}.{mod.name}")
        except Exception as exc:  # one broken reader must not hide the others
            problem = f"reader module {mod.name} failed to import: {type(exc).__name__}: {exc}"
            log.error("%s", problem)
            table.errors.append(problem)
            continue
        table.add_module(mod.name, module)
    return table


def find_reader(path: str | Path, fmt: str = "auto") -> Reader:
    """The reader for ``path``: by ``fmt`` (a format name or a suffix) or by its suffix.

    Raises :class:`ReaderError` naming the known formats when none fits.
    """
    table = reader_table()
    if fmt != "auto":
        key = fmt.lower()
        reader = table.by_name.get(key) or table.by_suffix.get(key if key.startswith(".")
                                                                 else "." + key)
        if reader is None:
            raise ReaderError(f"unknown recording format '{fmt}'; known: {_known(table)}")
        return reader
    suffix = Path(path).suffix.lower()
    reader = table.by_suffix.get(suffix)
    if reader is None:
        raise ReaderError(f"{path}: no reader for '{suffix or 'no suffix'}' files; "
                          f"known: {_known(table)} (or set `format`)")
    return reader


def _known(table: ReaderTable) -> str:
    names = sorted(table.by_suffix) + sorted(table.by_name)
    text = ", ".join(names) or "none"
    if table.errors:
        text += "; problems while loading readers: " + "; ".join(table.errors)
    return text
