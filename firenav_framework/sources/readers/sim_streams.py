"""Reader of simulation outputs (``streams.jsonl``, docs/formats/simulation-output.md).

``firenav simulate SCENARIO --out DIR`` writes ``DIR/streams.jsonl``: a header line
naming the IMU CSV files and the truth file, then one JSON object per sensor message.
Replaying that one file gives the whole run: the messages of the JSON lines (ports
``uwb``, ``rssi``, ``drops``, ``rfid``, ``tags``), the IMU blocks of the listed CSV
files (port ``imu``, read by the IMU CSV reader) and the ground truth of
``truth.csv`` (port ``truth``), merged in time order.

Lines that are not valid JSON, lack fields or have an unknown ``type`` are skipped and
counted (``bad_rows``, ``unknown_records``); a file whose first line is not the header,
or whose header lists a missing IMU or truth file, is a :class:`ReaderError` when the
file is opened. A listed file that turns out unreadable (empty, garbage, cut off) costs
only its own data: it is counted (``unreadable_files``) and reported, and every other
firefighter's data go on. The inputs are merged by
:func:`~firenav_framework.time_merge.merge_in_time`, so one device's clock jump or
corrupt stamp does not hold the others back.
"""
from __future__ import annotations

import json
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

import numpy as np

from ...messages import (BreadcrumbDrop, GroundTruth, Message, Range, RawFrame,
                         RssiReading, TagDeployment, TagDetection)
from ...formats.base import ReaderError, ReadOptions
from ...formats.imu_csv import ImuCsvReader
from ...time_merge import merge_in_time
from ...timeline import TimelineConfig

FORMAT = "firenav-sim-streams"

PORTS = {"uwb": Range, "rssi": RssiReading, "drops": BreadcrumbDrop, "rfid": TagDetection,
         "tags": TagDeployment, "baro": RawFrame}

#: ``type`` of a record -> message class and its (field, converter) list.
_RECORDS = {
    "range": (Range, (("a", str), ("b", str), ("range_m", float), ("sigma_m", float),
                      ("method", str), ("nlos", bool))),
    "rssi": (RssiReading, (("tx", str), ("rx", str), ("rssi_dbm", float))),
    "breadcrumb_drop": (BreadcrumbDrop, (("node_id", str),)),
    "tag_detection": (TagDetection, (("tag_id", str), ("reader", str), ("rssi_dbm", float),
                                     ("reads", int))),
    "tag_deployment": (TagDeployment, (("tag_id", str),)),
    "raw_frame": (RawFrame, (("transport", str), ("channel", str),
                             ("data", lambda v: str(v).encode("latin-1")))),
}
_DEFAULT_PORT = {"range": "uwb", "rssi": "rssi", "breadcrumb_drop": "drops",
                 "tag_detection": "rfid", "tag_deployment": "tags", "raw_frame": "baro"}


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
        with open(self.path, "rb") as fh:
            try:
                first = fh.readline(1 << 20).decode("utf-8")
            except UnicodeDecodeError:
                raise ReaderError(f"{self.path}: not UTF-8 text; expected JSON lines") from None
        try:
            head = json.loads(first) if first.strip() else {}
        except json.JSONDecodeError:
            raise ReaderError(f"{self.path}: the first line is not JSON; expected a "
                              "firenav simulation streams file") from None
        if not (isinstance(head, dict) and head.get("format") == FORMAT):
            raise ReaderError(f"{self.path}: " + ("the file is empty" if not first.strip()
                              else "the first line is not its header") +
                              f"; a firenav simulation streams file starts with "
                              f'{{"format": "{FORMAT}", ...}} naming its IMU and truth files '
                              "(`firenav simulate` writes it)")
        self.header = head
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
        with open(self.path, encoding="utf-8", errors="replace") as fh:
            for i, line in enumerate(fh):
                if not line.strip() or i == 0:
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
        with open(self.truth_file, encoding="utf-8", errors="replace") as fh:
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

    def _contained(self, path: Path, items: Callable[[], Iterable[tuple[str, Message]]]
                   ) -> Iterator[tuple[str, Message]]:
        """One listed file's messages; if it cannot be read (on) only it is lost."""
        try:
            yield from items()
        except (ReaderError, ValueError, OSError) as exc:
            self.options.count("unreadable_files", 1)
            text = str(exc) if str(exc).startswith(str(path)) else f"{path}: {exc}"
            self.options.warn("unreadable_file", f"{text}; the rest of this file is "
                              "skipped, the other files go on")

    def __iter__(self) -> Iterator[tuple[str, Message]]:
        its = [self._records()]
        for f in self.imu_files:
            its.append(self._contained(f, lambda f=f: ImuCsvReader(f, self.options)))
        if self.truth_file is not None:
            its.append(self._contained(self.truth_file, self._truth))
        rules = TimelineConfig()  # one device's clock jump must not reorder the others
        yield from merge_in_time(its, time_of=lambda pm: pm[1].t, max_lead=rules.max_lead,
                                 jump_back=rules.clock_jump)


READERS = {".jsonl": SimStreamsReader}
FORMATS = {"sim_streams": SimStreamsReader}
