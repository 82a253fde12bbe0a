"""Writing a simulation to a folder (``firenav simulate SCENARIO --out DIR``).

The files (specified in ``docs/formats/simulation-output.md``):

* ``imu_<agent>.csv``: the foot IMU in the firenav IMU CSV format, device axes;
* ``streams.jsonl``: a header line, then every other sensor message (UWB ranges,
  RSSI readings, breadcrumb drops, RFID detections, tag deployments, barometer lines
  as ``raw_frame`` records) one JSON object
  per line in time order; the ``recording`` source replays the whole run from it;
* ``truth.csv``: the body ground truth per agent at the truth rate;
* ``truth.json``: what does not move or is drawn once: tag, breadcrumb and anchor
  positions (and what became of the breadcrumbs), checkpoints, the people, the IMU
  errors and radio path loss drawn for this seed, how the world differs from the plan;
* ``foot_<agent>.csv`` (``foot_truth=True``): the instrumented foot at every IMU
  sample (position, velocity, attitude, stance);
* ``scenario.yaml``: the scenario as run.
"""
from __future__ import annotations

import json
import math
import shutil
from pathlib import Path
from typing import Any

import numpy as np

from ..messages import (BreadcrumbDrop, Message, Range, RawFrame, RssiReading, TagDeployment,
                        TagDetection)
from ..formats.imu_csv import write_imu_csv
from .result import SimulationResult
from .world import describe

FORMAT = "firenav-sim-streams"
VERSION = 1

#: Message class <-> the ``type`` written in streams.jsonl, and its fields.
MESSAGE_FIELDS: dict[str, tuple[type[Message], tuple[str, ...]]] = {
    "range": (Range, ("a", "b", "range_m", "sigma_m", "method", "nlos")),
    "rssi": (RssiReading, ("tx", "rx", "rssi_dbm")),
    "breadcrumb_drop": (BreadcrumbDrop, ("node_id",)),
    "tag_detection": (TagDetection, ("tag_id", "reader", "rssi_dbm", "reads")),
    "tag_deployment": (TagDeployment, ("tag_id",)),
    "raw_frame": (RawFrame, ("transport", "channel", "data")),
}
_TYPE_OF = {cls: name for name, (cls, _) in MESSAGE_FIELDS.items()}


def _num(v: float) -> float | None:
    return None if v is None or not math.isfinite(v) else float(v)


def message_record(port: str, msg: Message) -> dict[str, Any]:
    """One streams.jsonl record of ``msg`` (published on ``port``)."""
    kind = _TYPE_OF[type(msg)]
    rec: dict[str, Any] = {"port": port, "type": kind, "t": msg.t, "agent": msg.agent,
                           "device": msg.device}
    for f in MESSAGE_FIELDS[kind][1]:
        v = getattr(msg, f)
        rec[f] = _num(v) if isinstance(v, float) else v.decode("latin-1") if isinstance(
            v, bytes) else v
    return rec


def _jsonable(v: Any) -> Any:
    if isinstance(v, np.ndarray):
        return [_jsonable(x) for x in v.tolist()]
    if isinstance(v, (np.floating, float)):
        return None if not math.isfinite(float(v)) else round(float(v), 6)
    if isinstance(v, np.integer):
        return int(v)
    if isinstance(v, dict):
        return {str(k): _jsonable(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_jsonable(x) for x in v]
    return v


def write_simulation(result: SimulationResult, out: str | Path, *, foot_truth: bool = False
                     ) -> list[Path]:
    """Write ``result`` under folder ``out`` (created); returns the files written."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    imu_files = {}
    for agent, rec in result.imu.items():
        path = out / f"imu_{agent}.csv"
        write_imu_csv(path, rec.blocks(10.0))
        imu_files[agent] = path.name
        written.append(path)
    extra = {port: iter(rows) for port, rows in result.extra.items()}
    header = {"format": FORMAT, "version": VERSION, "scenario": result.scenario.name,
              "seed": result.seed, "t_end": round(result.t_end, 6), "imu_files": imu_files,
              "truth_file": "truth.csv", "static_truth_file": "truth.json",
              "ports": sorted(p for p in result.messages if p != "truth")}
    path = out / "streams.jsonl"
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(json.dumps(header) + "\n")
        streams = {p: m for p, m in result.messages.items() if p != "truth"}
        for port, msg in _merged(streams):
            rec = message_record(port, msg)
            if port in extra:
                rec["truth"] = next(extra[port])
            fh.write(json.dumps(rec, separators=(",", ":")) + "\n")
    written.append(path)
    written.append(_write_truth_csv(result, out / "truth.csv"))
    written.append(_write_static_truth(result, out / "truth.json"))
    if foot_truth:
        for agent, tr in result.truth.items():
            if tr.foot is not None:
                written.append(_write_foot(tr.foot, out / f"foot_{agent}.csv"))
    scen = Path(result.scenario.file)
    if scen.is_file():
        shutil.copyfile(scen, out / "scenario.yaml")
        written.append(out / "scenario.yaml")
    return written


def _merged(streams: dict[str, list[Message]]):
    import heapq

    def tagged(port, msgs):
        for m in msgs:
            yield port, m
    return heapq.merge(*(tagged(p, m) for p, m in streams.items()), key=lambda pm: pm[1].t)


TRUTH_COLUMNS = "t,agent,x,y,z,heading,floor,motion"


def _write_truth_csv(result: SimulationResult, path: Path) -> Path:
    rows = []
    for agent, tr in result.truth.items():
        for i in range(len(tr.t)):
            rows.append((tr.t[i], agent, tr.position[i], tr.heading[i], tr.floor[i], tr.motion[i]))
    rows.sort(key=lambda r: (r[0], r[1]))
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(TRUTH_COLUMNS + "\n")
        for t, a, p, h, f, m in rows:
            fh.write(f"{t:.4f},{a},{p[0]:.4f},{p[1]:.4f},{p[2]:.4f},{h:.5f},{int(f)},{m}\n")
    return path


def _write_static_truth(result: SimulationResult, path: Path) -> Path:
    doc = {
        "scenario": result.scenario.name, "seed": result.seed, "t_end": result.t_end,
        "building": str(result.scenario.building_path.name),
        "anchors": result.anchors, "tags": result.tags, "breadcrumbs": result.breadcrumbs,
        "radio": result.radio,
        "world": None if result.world is result.building else describe(result.world,
                                                                        result.building),
        "checkpoints": {a: [{"name": c.name, "t": c.t, "t_start": c.t_start, "t_end": c.t_end,
                             "position": c.position, "heading": c.heading}
                            for c in tr.checkpoints] for a, tr in result.truth.items()},
        "agents": {a: {"person": tr.person, "distance_m": tr.distance_m,
                       "imu": None if a not in result.imu else {
                           "device": result.imu[a].device, "grade": result.imu[a].grade,
                           "rate_hz": result.imu[a].rate_hz, "frame": result.imu[a].frame,
                           "saturated_samples": int(result.imu[a].saturated.sum()),
                           "errors": result.imu[a].errors}}
                   for a, tr in result.truth.items()},
    }
    path.write_text(json.dumps(_jsonable(doc), indent=1) + "\n", encoding="utf-8")
    return path


FOOT_COLUMNS = "t,x,y,z,vx,vy,vz,yaw,pitch,roll,stance"


def _write_foot(kin, path: Path) -> Path:
    data = np.column_stack([kin.t, kin.position, kin.velocity, kin.euler,
                            kin.stance.astype(float)])
    np.savetxt(path, data, delimiter=",", header=FOOT_COLUMNS, comments="",
               fmt=["%.5f"] + ["%.6f"] * 9 + ["%d"])
    return path
