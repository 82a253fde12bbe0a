"""Reader of simulation outputs (``streams.jsonl``, docs/formats/simulation-output.md).

``firenav simulate SCENARIO --out DIR`` writes ``DIR/streams.jsonl``: a header line
naming the IMU CSV files and the truth file, then one JSON object per sensor message.
Replaying that one file gives the whole run: the messages of the JSON lines (ports
``uwb``, ``rssi``, ``drops``, ``rfid``, ``tags``), the IMU blocks of the listed CSV
files (port ``imu``, read by the IMU CSV reader) and the ground truth of
``truth.csv`` (port ``truth``), merged in time order.

Lines that are not valid JSON, lack fields or have an unknown ``type`` are skipped and
counted (``bad_rows``, ``unknown_records``); a missing IMU or truth file listed in the
header is a :class:`ReaderError` when the file is opened.
"""
from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from ...messages import (BreadcrumbDrop, GroundTruth, Message, Range, RssiReading,
                         TagDeployment, TagDetection)
from ...formats.base import ReaderError, ReadOptions
from ...formats.imu_csv import ImuCsvReader
from ...time_merge import merge_in_time
from ...timeline import TimelineConfig

FORMAT = "firenav-sim-streams"

PORTS = {"uwb": Range, "rssi": RssiReading, "drops": BreadcrumbDrop, "rfid": TagDetection,
         "tags": TagDeployment}

#: ``type`` of a record -> message class and its (field, converter) list.
_RECORDS = {
    "range": (Range, (("a", str), ("b", str), ("range_m", float), ("sigma_m", float),
                      ("method", str), ("nlos", bool))),
    "rssi": (RssiReading, (("tx", str), ("rx", str), ("rssi_dbm", float))),
    "breadcrumb_drop": (BreadcrumbDrop, (("node_id", str),)),
    "tag_detection": (TagDetection, (("tag_id", str), ("reader", str), ("rssi_dbm", float),
                                     ("reads", int))),
    "tag_deployment": (TagDeployment, (("tag_id", str),)),
}
_DEFAULT_PORT = {"range": "uwb", "rssi": "rssi", "breadcrumb_drop": "drops",
                 "tag_detection": "rfid", "tag_deployment": "tags"}


def parse_record(rec: dict) -> tuple[str, Message]:
    """(port, message) of one streams.jsonl record; ValueError/KeyError if malformed."""
    kind = rec["type"]
    cls, fields = _RECORDS[kind]
    kw = {}
    for name, conv in fields:
        v = rec.get(name)
        if v is None:
            if name == "rssi_dbm" and cls is TagDetection:
                kw[name] = None
                continue
            if name in ("nlos", "method", "reader"):
                continue
            raise KeyError(name)
        kw[name] = conv(v)
    t = float(rec["t"])
    if not np.isfinite(t):
        raise ValueError("time is not finite")
    msg = cls(t=t, agent=str(rec.get("agent", "")), device=str(rec.get("device", "")), **kw)
    return str(rec.get("port") or _DEFAULT_PORT[kind]), msg


class SimStreamsReader:
    """Replays a simulation folder from its ``streams.jsonl``."""

    def __init__(self, path: Path, options: ReadOptions):
        self.path = Path(path)
        self.options = options
        try:
            with open(self.path, encoding="utf-8") as fh:
                first = fh.readline()
        except UnicodeDecodeError:
            raise ReaderError(f"{self.path}: not UTF-8 text; expected JSON lines") from None
        try:
            head = json.loads(first) if first.strip() else {}
        except json.JSONDecodeError:
            raise ReaderError(f"{self.path}: the first line is not JSON; expected a "
                              "firenav simulation streams file") from None
        self.header = head if isinstance(head, dict) and head.get("format") == FORMAT else {}
        base = self.path.parent
        self.imu_files = [base / name for name in (self.header.get("imu_files") or {}).values()]
        truth = self.header.get("truth_file")
        self.truth_file = base / truth if truth else None
        for f in self.imu_files + ([self.truth_file] if self.truth_file else []):
            if not f.is_file():
                raise ReaderError(f"{self.path}: the header lists {f.name}, which is missing "
                                  f"(looked for {f})")

    def duration(self) -> tuple[float, float] | None:
        t_end = self.header.get("t_end")
        return (0.0, float(t_end)) if t_end is not None else None

    def _records(self) -> Iterator[tuple[str, Message]]:
        count = self.options.count
        with open(self.path, encoding="utf-8") as fh:
            for i, line in enumerate(fh):
                if not line.strip() or (i == 0 and self.header):
                    continue
                try:
                    rec = json.loads(line)
                    if rec.get("type") not in _RECORDS:
                        count("unknown_records", 1)
                        continue
                    yield parse_record(rec)
                except (ValueError, KeyError, TypeError, AttributeError):
                    count("bad_rows", 1)

    def _truth(self) -> Iterator[tuple[str, Message]]:
        with open(self.truth_file, encoding="utf-8") as fh:
            fh.readline()
            for line in fh:
                parts = line.rstrip("\n").split(",")
                try:
                    t, agent = float(parts[0]), parts[1]
                    pos = np.array([float(parts[2]), float(parts[3]), float(parts[4])])
                    yield "truth", GroundTruth(t=t, agent=agent, position=pos,
                                               heading=float(parts[5]), floor=int(parts[6]))
                except (ValueError, IndexError):
                    self.options.count("bad_rows", 1)

    def __iter__(self) -> Iterator[tuple[str, Message]]:
        its = [self._records()]
        for f in self.imu_files:
            its.append(iter(ImuCsvReader(f, self.options)))
        if self.truth_file is not None:
            its.append(self._truth())
        rules = TimelineConfig()  # one device's clock jump must not reorder the others
        yield from merge_in_time(its, time_of=lambda pm: pm[1].t, max_lead=rules.max_lead,
                                 jump_back=rules.clock_jump)


READERS = {".jsonl": SimStreamsReader}
FORMATS = {"sim_streams": SimStreamsReader}
