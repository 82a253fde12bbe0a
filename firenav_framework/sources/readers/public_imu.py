"""Foot-IMU recordings of public projects, read as they are published.

Each format is a :class:`~firenav_framework.formats.csv_layout.CsvLayout` preset (its
columns, units and rate) recognised by its header, plus the ground truth where the
project publishes one next to the recording. Pages with a worked command each:
``docs/formats/xio-gait-tracking.md``, ``zupt-fgo.md``, ``gaitmap.md``, ``openshoe.md``.

``xio_gait_tracking``
    x-io Technologies' Gait-Tracking (NGIMU): ``Time (s)``, gyroscope in deg/s, then
    accelerometer in g.
``xio_ximu``
    x-io's older Gait-Tracking-With-x-IMU ``*_CalInertialAndMag.csv``: ``Packet number``
    (not a time: the rows are 1/256 s apart), gyroscope deg/s, accelerometer g,
    magnetometer gauss.
``zupt_fgo``
    Constrained-ZUPT-FGO ``measData/imuMeasLeft.csv`` / ``imuMeasRight.csv``:
    ``time_index`` at 60 Hz, m/s^2, rad/s (and the project's own ``is_zero_vel``, not
    used). Truth: ``positionGt.csv`` beside it (the foot the file name says), published
    on port ``truth``.
``gaitmap``
    gaitmap's two-sensor CSV: two header rows (``sensor``: left_sensor/right_sensor,
    ``axis``: acc_x ... gyr_z), the sample index first, m/s^2 and deg/s, in gaitmap's
    foot sensor frame (= FLU). The file does not store its rate: give it
    (``columns: {rate: 204.8}``).
``openshoe``
    OpenShoe's ``data_inert.txt``: whitespace-separated, one header line, a_x..a_z in
    g, ar_x..ar_z in rad/s, the filtered time stamp [s] in column 10 (0-based).
"""
from __future__ import annotations

import csv
import heapq
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...formats.base import ReaderError, ReadOptions
from ...formats.csv_layout import CsvColumns, CsvLayout, LayoutCsvReader
from ...messages import GroundTruth, Message

__all__ = ["Preset", "PRESETS", "detect_preset", "read_preset", "read_with_layout"]

_XIO_GYRO = ["Gyroscope X (deg/s)", "Gyroscope Y (deg/s)", "Gyroscope Z (deg/s)"]
_XIO_ACCEL = ["Accelerometer X (g)", "Accelerometer Y (g)", "Accelerometer Z (g)"]
_FGO_COLUMNS = ["time_index", "acc_x", "acc_y", "acc_z", "gyro_x", "gyro_y", "gyro_z"]
_GAITMAP_AXES = ["acc_x", "acc_y", "acc_z", "gyr_x", "gyr_y", "gyr_z"]
#: Constrained-ZUPT-FGO's IMU rate (its ``customized_all_*_imu.yaml``: update_rate 60).
ZUPT_FGO_RATE = 60.0
#: The x-IMU's inertial rate in Gait-Tracking-With-x-IMU (``Script.m``: samplePeriod 1/256).
XIMU_RATE = 256.0


@dataclass(frozen=True)
class Preset:
    """A public format: does a header look like it, and its layout for that header."""

    name: str
    matches: Callable[[list[list[str]]], bool]     # the first two lines, split at commas
    layout: Callable[[list[list[str]]], dict]       # CsvLayout keys for that header
    truth: Callable[[Path, ReadOptions], Iterator[GroundTruth]] | None = None


def _xio(head: list[list[str]]) -> bool:
    return bool(head) and head[0][:1] == ["Time (s)"] and all(
        c in head[0] for c in _XIO_GYRO + _XIO_ACCEL)


def _ximu(head: list[list[str]]) -> bool:
    return bool(head) and head[0][:1] == ["Packet number"] and all(
        c in head[0] for c in _XIO_GYRO + _XIO_ACCEL)


def _fgo(head: list[list[str]]) -> bool:
    return bool(head) and head[0][:len(_FGO_COLUMNS)] == _FGO_COLUMNS


def _gaitmap(head: list[list[str]]) -> bool:
    return (len(head) >= 2 and head[0][:1] == ["sensor"] and head[1][:1] == ["axis"]
            and all(a in head[1] for a in _GAITMAP_AXES))


def _openshoe(head: list[list[str]]) -> bool:
    first = head[0][0].split() if head and head[0] else []
    return bool(first) and first[0] in ("Header", "dummy_header") and len(head[0]) == 1


def _gaitmap_layout(head: list[list[str]]) -> dict:
    devices = list(dict.fromkeys(s for s in head[0][1:] if s))
    return {"time": 0, "time_unit": "sample", "header_rows": 2,
            "accel": ["{device}/acc_x", "{device}/acc_y", "{device}/acc_z"],
            "gyro": ["{device}/gyr_x", "{device}/gyr_y", "{device}/gyr_z"],
            "gyro_unit": "deg/s", "frame": "FLU", "devices": devices}


def _fgo_truth(path: Path, options: ReadOptions) -> Iterator[GroundTruth]:
    """``positionGt.csv`` beside an ``imuMeas<Foot>.csv``: that foot's position, turned
    from the file's north-east-down axes to ENU (x east = its y, y north = its x, z up =
    minus its z); times from ``time_index`` at 60 Hz."""
    gt = path.with_name("positionGt.csv")
    foot = "left" if "left" in path.stem.lower() else "right" if "right" in path.stem.lower() else None
    if foot is None or not gt.is_file():
        return
    with open(gt, encoding="utf-8", newline="") as fh:
        reader = csv.reader(fh)
        header = [c.strip() for c in next(reader, [])]
        cols = ["time_index"] + [f"pos_{foot}_{a}" for a in "xyz"]
        if not all(c in header for c in cols):
            raise ReaderError(f"{gt}: expected columns {', '.join(cols)}")
        idx = [header.index(c) for c in cols]
        bad = 0
        for row in reader:
            try:
                k, n, e, d = (float(row[i]) for i in idx)
            except (ValueError, IndexError):
                bad += 1
                continue
            yield GroundTruth(t=k / ZUPT_FGO_RATE, agent=options.agent, device=f"gt_{foot}",
                              position=np.array([e, n, -d]), frame="zupt_fgo")
        if bad:
            options.count("bad_truth_rows", bad)


PRESETS: dict[str, Preset] = {p.name: p for p in (
    Preset("xio_gait_tracking", _xio, lambda head: {
        "time": "Time (s)", "accel": _XIO_ACCEL, "gyro": _XIO_GYRO, "accel_unit": "g",
        "gyro_unit": "deg/s"}),
    Preset("xio_ximu", _ximu, lambda head: {
        "time": None, "rate": XIMU_RATE, "accel": _XIO_ACCEL, "gyro": _XIO_GYRO,
        "accel_unit": "g", "gyro_unit": "deg/s",
        **({"mag": ["Magnetometer X (G)", "Magnetometer Y (G)", "Magnetometer Z (G)"],
            "mag_unit": "gauss"} if "Magnetometer X (G)" in head[0] else {})}),
    Preset("zupt_fgo", _fgo, lambda head: {
        "time": "time_index", "time_unit": "sample", "rate": ZUPT_FGO_RATE,
        "accel": _FGO_COLUMNS[1:4], "gyro": _FGO_COLUMNS[4:7]}, truth=_fgo_truth),
    Preset("gaitmap", _gaitmap, _gaitmap_layout),
    Preset("openshoe", _openshoe, lambda head: {
        "delimiter": "whitespace", "time": 10, "accel": [1, 2, 3], "gyro": [4, 5, 6],
        "accel_unit": "g"}),
)}


def read_head(path: Path, lines: int = 2) -> list[list[str]]:
    """The first ``lines`` lines of a text file, split at commas and stripped."""
    out = []
    with open(path, encoding="utf-8", errors="replace", newline="") as fh:
        for _ in range(lines):
            line = fh.readline()
            if not line:
                break
            out.append([c.strip() for c in line.rstrip("\r\n").split(",")])
    return out


def detect_preset(path: Path) -> Preset | None:
    """The public format whose header ``path`` starts with, or None."""
    head = read_head(path)
    return next((p for p in PRESETS.values() if p.matches(head)), None)


class _WithTruth:
    """IMU blocks and a truth port merged in time order."""

    def __init__(self, imu: LayoutCsvReader, truth: Iterator[GroundTruth]):
        self._imu, self._truth = imu, truth

    def duration(self) -> tuple[float, float] | None:
        return None

    def __iter__(self) -> Iterator[tuple[str, Message]]:
        return heapq.merge(iter(self._imu), (("truth", m) for m in self._truth),
                           key=lambda pm: pm[1].t)


def read_with_layout(path: Path, options: ReadOptions, layout: CsvLayout,
                     preset: Preset | None = None):
    """A reader of ``path`` with ``layout`` (and the preset's truth, if it has one)."""
    imu = LayoutCsvReader(path, options, layout)
    if preset is not None and preset.truth is not None:
        return _WithTruth(imu, preset.truth(path, options))
    return imu


def read_preset(name: str) -> Callable[[Path, ReadOptions], object]:
    """The reader of the ``format:`` name ``name``: its preset's layout for the file's
    header, with the ``columns`` option's keys over it."""
    preset = PRESETS[name]

    def reader(path: Path, options: ReadOptions):
        path = Path(path)
        base = preset.layout(read_head(path))
        layout = (options.columns or CsvColumns()).over(base, f"{path} ({name})")
        return read_with_layout(path, options, layout, preset)

    reader.__name__ = f"read_{name}"
    return reader


FORMATS = {name: read_preset(name) for name in PRESETS}
