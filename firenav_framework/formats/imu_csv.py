"""The firenav IMU CSV format: reader :class:`ImuCsvReader` and writer :func:`write_imu_csv`.

The simulator writes it and the ``recording`` source reads it (registered for
``.csv`` in :mod:`firenav_framework.sources.readers.imu_csv`); it lives here, owned by
neither.

The format is specified in ``docs/formats/imu-csv.md``. In short::

    # firenav imu-csv 1
    # accel_unit: m/s^2        (or g)
    # gyro_unit: rad/s         (or deg/s)
    # mag_unit: uT             (or gauss, nT)
    # frame: device            (axes of the columns: "device" or "FLU")
    # agent: ff1
    # device: ff1/imu
    t,ax,ay,az,gx,gy,gz,mx,my,mz,agent,device
    0.005,-2.78,0.30,-9.35,0.0040,0.0123,-0.0085,,,,
    ...

The reader converts the units to SI, splits rows by (agent, device) and yields
:class:`ImuBlock` pieces of ``block_s`` on port ``imu``, reading the file in chunks
so that long recordings do not have to fit in memory twice. Rows it cannot parse
(wrong number of fields, text where a number belongs) are skipped and counted as
``bad_rows``; ``nan``/``inf`` values are passed on for the sensor plugin to judge.
"""
from __future__ import annotations

from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import IO

import numpy as np

from ..messages import ImuBlock, Message
from .base import ReaderError, ReadOptions, chunked_imu, imu_blocks

__all__ = ["ImuCsvReader", "write_imu_csv", "UNIT_SCALES", "FORMAT_LINE"]

FORMAT_LINE = "# firenav imu-csv 1"
G0 = 9.80665  # m/s^2 per g (standard gravity, the definition of the unit)

#: SI factor of every unit the format accepts, per quantity.
UNIT_SCALES: dict[str, dict[str, float]] = {
    "accel_unit": {"m/s^2": 1.0, "g": G0},
    "gyro_unit": {"rad/s": 1.0, "deg/s": np.pi / 180.0},
    "mag_unit": {"uT": 1.0, "gauss": 100.0, "nT": 1e-3},
}
META_KEYS = ("accel_unit", "gyro_unit", "mag_unit", "frame", "agent", "device")
NUMERIC = ("t", "ax", "ay", "az", "gx", "gy", "gz")
MAG = ("mx", "my", "mz")
LABELS = ("agent", "device")
#: Rows parsed at once (memory stays bounded however long the file).
CHUNK_ROWS = 20000


class ImuCsvReader:
    """Reader of the firenav IMU CSV format (see the module docstring)."""

    def __init__(self, path: Path, options: ReadOptions):
        self.path = Path(path)
        self.options = options
        # a stray non-UTF-8 byte makes its row unparseable (counted), not the file unreadable
        with open(self.path, encoding="utf-8", errors="replace", newline="") as fh:
            self.meta, self.columns, self._data_line = _read_header(fh, self.path)
        self.frame = self.meta.get("frame", "device")
        self.scales = {q: UNIT_SCALES[q][self.meta.get(q, next(iter(UNIT_SCALES[q])))]
                       for q in UNIT_SCALES}

    def duration(self) -> tuple[float, float] | None:
        return None  # would need a pass over the whole file

    def __iter__(self) -> Iterator[tuple[str, Message]]:
        yield from chunked_imu(self.path, self._data_line, CHUNK_ROWS, self._chunk_blocks)

    def _labels(self, agent: str, device: str) -> tuple[str, str]:
        """Agent and device of a row: its own columns, else the header, else the options."""
        agent = agent or self.meta.get("agent") or self.options.agent
        device = device or self.meta.get("device") or (
            self.options.device if agent == self.options.agent else f"{agent}/imu")
        return agent, device

    def _chunk_blocks(self, lines: list[str]) -> list[list[ImuBlock]]:
        """The chunk's rows as blocks, one time-ordered list per (agent, device)."""
        rows = [ln.rstrip("\r\n").split(",") for ln in lines
                if ln.strip() and not ln.lstrip().startswith("#")]
        width = len(self.columns)
        good = [r for r in rows if len(r) == width]
        if len(good) < len(rows):
            self.options.count("bad_rows", len(rows) - len(good))
        if not good:
            return []
        table = np.array(good, dtype=str)
        col = {name: i for i, name in enumerate(self.columns)}
        numeric = [col[c] for c in NUMERIC] + ([col[c] for c in MAG] if "mx" in col else [])
        values, ok = _parse_floats(table[:, numeric])
        if not ok.all():
            self.options.count("bad_rows", int((~ok).sum()))
        table, values = table[ok], values[ok]
        if not len(values):
            return []
        blank = np.full(len(values), "")
        agents = np.char.strip(table[:, col["agent"]]) if "agent" in col else blank
        devices = np.char.strip(table[:, col["device"]]) if "device" in col else blank
        out = []
        keys = np.char.add(np.char.add(agents, "\n"), devices)
        for key in dict.fromkeys(keys.tolist()):  # first-appearance order
            sel = keys == key
            agent, device = self._labels(*key.split("\n", 1))
            v = values[sel]
            mag = v[:, 7:10] * self.scales["mag_unit"] if v.shape[1] > 7 else None
            if mag is not None and np.isnan(mag).all():
                mag = None
            out.append(list(imu_blocks(
                v[:, 0], v[:, 1:4] * self.scales["accel_unit"],
                v[:, 4:7] * self.scales["gyro_unit"], mag=mag, block_s=self.options.block_s,
                agent=agent, device=device, frame=self.frame)))
        return out


def _read_header(fh: IO[str], path: Path) -> tuple[dict[str, str], list[str], int]:
    """(metadata, column names, number of lines before the first data row)."""
    meta: dict[str, str] = {}
    for n, line in enumerate(fh, start=1):
        text = line.strip()
        if not text:
            continue
        if text.startswith("#"):
            key, sep, value = text[1:].partition(":")
            if sep and key.strip() in META_KEYS:
                meta[key.strip()] = value.strip()
            continue
        columns = [c.strip().strip('"').strip() for c in text.split(",")]  # quoted names too
        _check_header(path, meta, columns)
        return meta, columns, n
    raise ReaderError(f"{path}: no column header line (expected e.g. "
                      f"'{','.join(NUMERIC)}'); see docs/formats/imu-csv.md")


def _check_header(path: Path, meta: dict[str, str], columns: list[str]) -> None:
    missing = [c for c in NUMERIC if c not in columns]
    if missing:
        raise ReaderError(f"{path}: column header lacks {', '.join(missing)} (has "
                          f"{', '.join(columns)}); see docs/formats/imu-csv.md")
    mags = [c for c in MAG if c in columns]
    if mags and len(mags) != 3:
        raise ReaderError(f"{path}: magnetometer columns must be all of mx, my, mz or none")
    unknown = [c for c in columns if c not in NUMERIC + MAG + LABELS]
    dupes = {c for c in columns if columns.count(c) > 1}
    if unknown or dupes:
        raise ReaderError(f"{path}: unknown or repeated columns "
                          f"{', '.join(sorted(set(unknown) | dupes))}")
    for quantity, units in UNIT_SCALES.items():
        if quantity in meta and meta[quantity] not in units:
            raise ReaderError(f"{path}: {quantity} '{meta[quantity]}' is not one of "
                              f"{', '.join(units)}")


def _parse_floats(text: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Parse an (n, k) array of strings; rows with any unparseable field are not ok.

    Empty magnetometer fields mean "no reading" (NaN); empty inertial fields are bad.
    """
    text = np.char.strip(text)
    empty = text == ""
    if empty[:, 7:].any():
        text = np.where(empty & (np.arange(text.shape[1]) >= 7), "nan", text)
    try:
        return text.astype(float), np.ones(len(text), bool)
    except ValueError:
        pass
    values = np.full(text.shape, np.nan)
    ok = np.ones(len(text), bool)
    for i, row in enumerate(text.tolist()):  # only for chunks that hold a bad field
        try:
            values[i] = [float(v) for v in row]
        except ValueError:
            ok[i] = False
    return values, ok


def write_imu_csv(path: str | Path, blocks: Iterable[ImuBlock], *,
                  accel_unit: str = "m/s^2", gyro_unit: str = "rad/s",
                  mag_unit: str = "uT") -> Path:
    """Write IMU blocks (SI units, one axis frame) as a firenav IMU CSV file.

    Values are written in the given units with shortest round-trip precision, so a
    file written in SI reads back bit-exact. Blocks of several devices are written
    in the order given, with ``agent``/``device`` columns; a single device's labels
    go to the header instead. Raises ``ValueError`` for blocks in different frames
    or an unknown unit.
    """
    path = Path(path)
    blocks = list(blocks)
    for quantity, unit in (("accel_unit", accel_unit), ("gyro_unit", gyro_unit),
                           ("mag_unit", mag_unit)):
        if unit not in UNIT_SCALES[quantity]:
            raise ValueError(f"{quantity} '{unit}' is not one of {', '.join(UNIT_SCALES[quantity])}")
    frames = {b.frame for b in blocks}
    if len(frames) > 1:
        raise ValueError(f"blocks are in different frames ({', '.join(sorted(frames))}); "
                         "write one file per frame")
    labels = {(b.agent, b.device) for b in blocks}
    with_mag = any(b.mag is not None for b in blocks)
    header = [FORMAT_LINE, f"# accel_unit: {accel_unit}", f"# gyro_unit: {gyro_unit}"]
    if with_mag:
        header.append(f"# mag_unit: {mag_unit}")
    header.append(f"# frame: {frames.pop() if frames else 'device'}")
    columns = list(NUMERIC) + (list(MAG) if with_mag else [])
    if len(labels) == 1:
        agent, device = next(iter(labels))
        header += [f"# agent: {agent}", f"# device: {device}"]
    elif labels:
        columns += list(LABELS)
    sa = 1.0 / UNIT_SCALES["accel_unit"][accel_unit]
    sg = 1.0 / UNIT_SCALES["gyro_unit"][gyro_unit]
    sm = 1.0 / UNIT_SCALES["mag_unit"][mag_unit]
    with open(path, "w", encoding="utf-8", newline="") as fh:
        fh.write("\n".join(header + [",".join(columns)]) + "\n")
        for b in blocks:
            parts = [b.time[:, None], b.accel * sa if sa != 1 else b.accel,
                     b.gyro * sg if sg != 1 else b.gyro]
            if with_mag:
                parts.append(np.full((len(b), 3), np.nan) if b.mag is None
                             else (b.mag * sm if sm != 1 else b.mag))
            suffix = f",{b.agent},{b.device}" if len(labels) > 1 else ""
            rows = np.hstack(parts).tolist()
            fh.write("".join(",".join(map(repr, r)) + suffix + "\n" for r in rows))
    return path

