"""IMU text recordings (``.csv``, ``.txt``): the firenav IMU CSV format, a column mapping,
or a public project's format recognised by its header.

How a file is read, first match wins:

1. a column mapping is given (the ``recording`` source's ``columns``, a sidecar
   ``<stem>.columns.yaml`` or the folder's ``columns.yaml``): its keys over those of
   the public format the header shows, if any (:mod:`firenav_framework.formats.csv_layout`);
2. the firenav IMU CSV format (:mod:`firenav_framework.formats.imu_csv`);
3. a public format recognised by its header (:mod:`.public_imu`);
4. otherwise a :class:`ReaderError` saying what was expected and how to map the columns.
"""
from __future__ import annotations

from pathlib import Path

from ...formats.base import ReaderError, ReadOptions
from ...formats.csv_layout import CsvColumns, find_sidecar, load_sidecar
from ...formats.imu_csv import ImuCsvReader
from .public_imu import PRESETS, detect_preset, read_head, read_with_layout

__all__ = ["read_imu_text", "read_mapped"]


def read_mapped(path: Path, options: ReadOptions):
    """A text recording read through its column mapping (the ``columns`` option over the
    sidecar over the detected public format); ReaderError when there is none."""
    path = Path(path)
    preset = detect_preset(path)
    base = preset.layout(read_head(path)) if preset else {}
    sidecar = find_sidecar(path)
    if sidecar is not None:
        base = {**base, **load_sidecar(sidecar).keys()}
    where = f"{path}" + (f" (mapping {sidecar.name})" if sidecar else "")
    if options.columns is None and sidecar is None and preset is None:
        raise ReaderError(f"{path}: no column mapping: give the recording source "
                          "`columns:` or a sidecar file "
                          f"{path.stem}.columns.yaml (docs/formats/csv-columns.md)")
    layout = (options.columns or CsvColumns()).over(base, where)
    return read_with_layout(path, options, layout, preset)


def read_imu_text(path: Path, options: ReadOptions):
    """The reader of a ``.csv`` / ``.txt`` IMU recording (see the module docstring)."""
    path = Path(path)
    if options.columns is not None or find_sidecar(path) is not None:
        return read_mapped(path, options)
    try:
        return ImuCsvReader(path, options)
    except ReaderError as exc:
        if detect_preset(path) is not None:
            return read_mapped(path, options)
        raise ReaderError(f"{exc}; or describe the file's columns and units with the "
                          f"recording source's `columns:` or a sidecar {path.stem}.columns.yaml "
                          "(docs/formats/csv-columns.md); recognised public formats: "
                          f"{', '.join(PRESETS)}") from None


READERS = {".csv": read_imu_text, ".txt": read_imu_text}
FORMATS = {"imu_csv": ImuCsvReader, "csv_columns": read_mapped}
