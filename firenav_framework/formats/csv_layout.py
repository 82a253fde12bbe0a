"""Column and unit mapping for IMU text files that are not in the firenav IMU CSV format.

A column mapping (:class:`CsvColumns`) says where the samples are in a delimited text
file and in what units, so that any logger's CSV (or whitespace-separated text) replays
without a conversion script. It is given in the ``recording`` source's ``columns``
parameter, in a sidecar file next to the recording (:func:`find_sidecar`), or by the
preset of a public format (:mod:`firenav_framework.sources.readers.public_imu`); keys
given later replace earlier ones, and :meth:`CsvColumns.over` checks the result into a
:class:`CsvLayout`. Every key is specified in ``docs/formats/csv-columns.md``; in short::

    columns:
      time: time_index          # column of the time (name or 0-based index); unset: row number
      time_unit: sample         # s, ms, us, ns, or sample (a sample index: needs rate)
      rate: 60                  # [Hz] for sample-index time or no time column
      accel: [acc_x, acc_y, acc_z]
      gyro: [gyro_x, gyro_y, gyro_z]
      accel_unit: m/s^2         # or g
      gyro_unit: rad/s          # or deg/s
      devices: [left_sensor, right_sensor]   # several IMUs: "{device}" in the names
      header_rows: 2            # header lines, joined per column with "/"

:class:`LayoutCsvReader` reads such a file in chunks into :class:`ImuBlock` pieces (one
stream per device, ``frame="device"`` unless ``frame`` says ``FLU``); rows it cannot
parse are skipped and counted as ``bad_rows``.
"""
from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np
import yaml
from pydantic import ValidationError, field_validator

from ..contract.params import Params, param
from ..messages import ImuBlock, Message
from .base import ReaderError, ReadOptions, chunked_imu, imu_blocks
from .imu_csv import CHUNK_ROWS, UNIT_SCALES

__all__ = ["CsvLayout", "CsvColumns", "LayoutCsvReader", "find_sidecar", "load_sidecar",
           "SIDECAR_SUFFIX",
           "FOLDER_SIDECAR", "TIME_UNITS"]

#: Seconds per unit of the time column.
TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
#: ``<recording stem>.columns.yaml`` describes that one file ...
SIDECAR_SUFFIX = ".columns.yaml"
#: ... and ``columns.yaml`` every recording of its folder without a file of its own.
FOLDER_SIDECAR = "columns.yaml"

Column = str | int
TimeUnit = Literal["s", "ms", "us", "ns", "sample"]


class CsvColumns(Params):
    """Where the samples of a delimited text file are, and in what units: the
    ``recording`` source's ``columns`` parameter and the keys of a sidecar file. Unset
    keys come from the public format the header shows (or from the sidecar), else the
    defaults named here; :meth:`over` checks the result."""

    time: Column | None = param(None)
    """column of the time or sample index (name, or 0-based index); unset: the row number"""
    time_unit: TimeUnit | None = param(None)
    """unit of the time column: s (default), ms, us, ns, or sample (an index: time = index / rate)"""
    rate: float | None = param(None, unit="Hz", gt=0)
    """sample rate, for sample-index time or no time column"""
    accel: tuple[Column, Column, Column] | None = param(None)
    """specific force x, y, z columns"""
    gyro: tuple[Column, Column, Column] | None = param(None)
    """angular rate x, y, z columns"""
    mag: tuple[Column, Column, Column] | None = param(None)
    """magnetic field x, y, z columns (optional)"""
    accel_unit: Literal["m/s^2", "g"] | None = param(None)
    """m/s^2 (default) or g"""
    gyro_unit: Literal["rad/s", "deg/s"] | None = param(None)
    """rad/s (default) or deg/s"""
    mag_unit: Literal["uT", "gauss", "nT"] | None = param(None)
    """uT (default), gauss or nT"""
    frame: Literal["device", "FLU"] | None = param(None)
    """axes of the columns: device (default) or FLU"""
    devices: list[str] | None = param(None, min_length=1)
    """several IMUs in one file: their names, put for '{device}' in the column names (device id
    '<agent>/<name>')"""
    delimiter: str | None = param(None)
    """field separator (default ','); 'whitespace' for any run of spaces and tabs"""
    header_rows: int | None = param(None, ge=0, le=10)
    """lines of column names (default 1; several are joined per column with '/'); 0: columns are
    0-based indices"""
    skip_rows: int | None = param(None, ge=0)
    """lines before the header (default 0)"""

    @field_validator("delimiter")
    @classmethod
    def _delimiter(cls, value: str | None) -> str | None:
        if value is not None and value != WHITESPACE and (len(value) != 1 or value in "\r\n\"'"):
            raise ValueError(f"delimiter must be one character or '{WHITESPACE}', got {value!r}")
        return value

    def keys(self) -> dict:
        """The keys that were given."""
        return self.model_dump(exclude_unset=True)

    def over(self, base: dict, where: str) -> CsvLayout:
        """The layout of ``base`` (keys of a preset or sidecar) with these keys set,
        checked; ReaderError naming ``where`` when it is incomplete or inconsistent."""
        k = {**base, **self.keys()}
        problems = [f"`{name}` is missing" for name in ("accel", "gyro") if k.get(name) is None]
        time, unit, rate = k.get("time"), k.get("time_unit") or "s", k.get("rate")
        if (time is None or unit == "sample") and rate is None:
            what = "no time column" if time is None else "a sample-index time column"
            problems.append(f"{what} needs `rate` (the sample rate in Hz)")
        header_rows = 1 if k.get("header_rows") is None else k["header_rows"]
        cols = [c for key in ("accel", "gyro", "mag") for c in (k.get(key) or ())]
        cols += [time] if time is not None else []
        named = [c for c in cols if isinstance(c, str)]
        if header_rows == 0 and named:
            problems.append(f"without header rows columns are 0-based indices, got {named[0]!r}")
        if any("{device}" in c for c in named) != bool(k.get("devices")):
            problems.append("`devices` and '{device}' in the column names go together")
        if problems:
            raise ReaderError(f"{where}: incomplete column mapping: {'; '.join(problems)} "
                              "(see docs/formats/csv-columns.md)")
        delimiter = k.get("delimiter") or ","
        return CsvLayout(
            time=time, time_unit=unit, rate=rate, accel=tuple(k["accel"]),
            gyro=tuple(k["gyro"]), mag=tuple(k["mag"]) if k.get("mag") else None,
            accel_unit=k.get("accel_unit") or "m/s^2", gyro_unit=k.get("gyro_unit") or "rad/s",
            mag_unit=k.get("mag_unit") or "uT", frame=k.get("frame") or "device",
            devices=tuple(k["devices"]) if k.get("devices") else None,
            delimiter=None if delimiter == WHITESPACE else delimiter,
            header_rows=header_rows, skip_rows=k.get("skip_rows") or 0)


#: The ``delimiter`` value for any run of whitespace.
WHITESPACE = "whitespace"


@dataclass(frozen=True)
class CsvLayout:
    """A complete, checked column mapping (:meth:`CsvColumns.over` makes one)."""

    time: Column | None
    time_unit: TimeUnit
    rate: float | None
    accel: tuple[Column, ...]
    gyro: tuple[Column, ...]
    mag: tuple[Column, ...] | None
    accel_unit: str
    gyro_unit: str
    mag_unit: str
    frame: str
    devices: tuple[str, ...] | None
    delimiter: str | None          # None: any whitespace
    header_rows: int
    skip_rows: int

    def device_names(self) -> list[str | None]:
        """The IMUs of the file (None: one, named by the recording's options)."""
        return list(self.devices) if self.devices else [None]


def load_sidecar(path: Path) -> CsvColumns:
    """Read a sidecar YAML file: the mapping's keys, at the top or under ``columns:``."""
    try:
        data = yaml.safe_load(Path(path).read_text(encoding="utf-8"))
    except (OSError, yaml.YAMLError) as exc:
        raise ReaderError(f"{path}: cannot read the column mapping ({exc})") from None
    if isinstance(data, dict) and set(data) == {"columns"}:
        data = data["columns"]
    try:
        return CsvColumns.model_validate(data)
    except ValidationError as exc:
        raise ReaderError(f"{path}: bad column mapping: {_problems(exc)} "
                          "(see docs/formats/csv-columns.md)") from None


def _problems(exc: ValidationError) -> str:
    return "; ".join(f"{'.'.join(map(str, e['loc'])) or 'columns'}: {e['msg']}"
                     for e in exc.errors())


def find_sidecar(recording: Path) -> Path | None:
    """The sidecar describing ``recording``: ``<stem>.columns.yaml`` beside it, else the
    folder's ``columns.yaml``, else None."""
    recording = Path(recording)
    for candidate in (recording.with_name(recording.stem + SIDECAR_SUFFIX),
                      recording.with_name(FOLDER_SIDECAR)):
        if candidate.is_file():
            return candidate
    return None


def _split(line: str, delimiter: str | None) -> list[str]:
    return [f.strip() for f in (line.split(delimiter) if delimiter else line.split())]


class LayoutCsvReader:
    """Reader of a delimited text file described by a :class:`CsvLayout`."""

    def __init__(self, path: Path, options: ReadOptions, layout: CsvLayout):
        self.path = Path(path)
        self.options = options
        self.layout = layout
        with open(self.path, encoding="utf-8", errors="replace", newline="") as fh:
            head = [fh.readline() for _ in range(layout.skip_rows + layout.header_rows)]
        names = self._header_names(head[layout.skip_rows:])
        self._first_data = layout.skip_rows + layout.header_rows
        self._indices = {dev: self._resolve(names, dev) for dev in layout.device_names()}
        self._width = max(max(ix) for ix in self._indices.values()) + 1
        self._row = 0                      # data rows read so far (row-number time)

    def duration(self) -> tuple[float, float] | None:
        return None

    # -- header ---------------------------------------------------------------------
    def _header_names(self, lines: list[str]) -> list[str]:
        if len(lines) < self.layout.header_rows or (lines and not lines[-1]):
            raise ReaderError(f"{self.path}: fewer lines than the {self.layout.header_rows} "
                              "header row(s) the column mapping names")
        rows = [_split(ln.rstrip("\r\n"), self.layout.delimiter) for ln in lines]
        width = max((len(r) for r in rows), default=0)
        rows = [r + [""] * (width - len(r)) for r in rows]
        return ["/".join(p for p in parts if p) for parts in zip(*rows)] if rows else []

    def _resolve(self, names: list[str], device: str | None) -> list[int]:
        """0-based indices of [time?, accel xyz, gyro xyz, mag xyz?] for one device."""
        lay = self.layout

        def index(col: Column) -> int:
            if isinstance(col, int):
                return col
            name = col.replace("{device}", device or "")
            if name in names:
                return names.index(name)
            close = [n for n in names if n.lower() == name.lower()]
            hint = f"; did you mean '{close[0]}'?" if close else ""
            raise ReaderError(f"{self.path}: no column '{name}' (the header has "
                              f"{', '.join(repr(n) for n in names[:20])}"
                              f"{' ...' if len(names) > 20 else ''}){hint}; "
                              "see docs/formats/csv-columns.md")

        cols = ([lay.time] if lay.time is not None else []) + [*lay.accel, *lay.gyro,
                                                               *(lay.mag or ())]
        return [index(c) for c in cols]

    # -- data -----------------------------------------------------------------------
    def __iter__(self) -> Iterator[tuple[str, Message]]:
        yield from chunked_imu(self.path, self._first_data, CHUNK_ROWS, self._chunk)

    def _chunk(self, lines: list[str]) -> list[list[ImuBlock]]:
        lay = self.layout
        rows = [_split(ln.rstrip("\r\n"), lay.delimiter) for ln in lines
                if ln.strip() and not ln.lstrip().startswith("#")]
        good = [r for r in rows if len(r) >= self._width]
        row_no = self._row + np.arange(len(rows))[[len(r) >= self._width for r in rows]]
        self._row += len(rows)
        if len(good) < len(rows):
            self.options.count("bad_rows", len(rows) - len(good))
        if not good:
            return []
        table = np.array([r[:self._width] for r in good], dtype=object)
        out = []
        for device, idx in self._indices.items():
            values, ok = _floats(table[:, idx])
            if not ok.all():
                self.options.count("bad_rows", int((~ok).sum()))
            values, rows_ok = values[ok], row_no[ok]
            if not len(values):
                continue
            t, rest = self._time(values, rows_ok)
            accel = rest[:, 0:3] * UNIT_SCALES["accel_unit"][lay.accel_unit]
            gyro = rest[:, 3:6] * UNIT_SCALES["gyro_unit"][lay.gyro_unit]
            mag = (rest[:, 6:9] * UNIT_SCALES["mag_unit"][lay.mag_unit]
                   if lay.mag is not None else None)
            agent = self.options.agent
            name = self.options.device if device is None else f"{agent}/{device}"
            out.append(list(imu_blocks(t, accel, gyro, mag=mag, block_s=self.options.block_s,
                                       agent=agent, device=name, frame=lay.frame)))
        return out

    def _time(self, values: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(time [s], the remaining columns) of parsed rows."""
        lay = self.layout
        if lay.time is None:
            return rows / lay.rate, values
        t = values[:, 0]
        t = t / lay.rate if lay.time_unit == "sample" else t * TIME_UNITS[lay.time_unit]
        return t, values[:, 1:]


_NUMBER = re.compile(r"^[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$|^[+-]?(nan|inf)$", re.I)


def _floats(text: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Parse an (n, k) array of strings; rows with a field that is not a number are not ok."""
    try:
        return text.astype(float), np.ones(len(text), bool)
    except ValueError:
        pass
    ok = np.array([all(_NUMBER.match(v) for v in row) for row in text.tolist()], bool)
    values = np.full(text.shape, np.nan)
    if ok.any():
        values[ok] = text[ok].astype(float)
    return values, ok
