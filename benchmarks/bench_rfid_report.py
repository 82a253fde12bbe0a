"""The RFID/MEMS EKF beside INS alone and the paper's method, on the same runs.

    .venv/bin/python benchmarks/bench_rfid_report.py rfid_route --seeds 1000-1019
    .venv/bin/python benchmarks/bench_rfid_report.py field_rfid_uncalibrated --seeds 1000-1019 \\
        --json out/rfid-field.json
    .venv/bin/python benchmarks/bench_rfid_report.py field_rfid_uncalibrated --seeds 100-119 \\
        --variant rate0=process.heading_rate_sigma=0          # tuning seeds only

Each seed is one simulation; every row below runs in the same pipeline on the same foot-INS
strides and tag events:

* ``ins``      - INS alone: ``dead_reckoning`` started at the true pose (pipelines/ins-baseline.yaml);
* ``mems``     - the paper's MEMS alone: pdr_ekf without tags or map aid (rfid-mems-baseline.yaml);
* ``paper``    - the paper's method as published (pipelines/rfid-ekf-as-published.yaml);
* ``firenav``  - firenav's pipeline (rfid-ekf.yaml on the paper scenario, rfid-ekf-field.yaml
  on the field family);
* ``--variant NAME=KEY=VALUE[,KEY=VALUE]``: firenav's filter with overrides (tuning).

The foot INS is the pipeline's: on ``rfid_route`` (the paper's still start) the gyro bias
from 5 s of it, as rfid-ekf.yaml; elsewhere zupt_ins defaults (no still start).

Figures per row: the paper's metric (rfid-mems-ekf "Performance assessment", Fig. 5: the
planimetric error at each RFID location, taken at the last pose before the read, where it
peaks), mean and std over every read of every agent and run; the RMSE over the dense
track pooled over runs, and per run min / median / max; the share of runs whose RMSE beats
INS alone's; floor right; the integrity figures of ``firenav evaluate`` (95 % ellipse
containment pooled and the worst run, trusted while > 3 m off: the worst run).
"""
from __future__ import annotations

import argparse
import copy
import json
import sys
import time
from collections import defaultdict
from pathlib import Path

import numpy as np
import yaml

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from benchmarks.bench_rfid_ekf import TAG_STREAMS, tag_times  # noqa: E402
from firenav_framework.evaluation.metrics import integrity_figures, track_errors  # noqa: E402
from firenav_framework.evaluation.seeds import parse_seeds  # noqa: E402
from firenav_framework.pipeline import load_pipeline_text  # noqa: E402
from tests.rfid.harness import run_tapped  # noqa: E402

PIPES = REPO / "pipelines"
CALIBRATED = {"alignment": {"gyro_bias": True, "duration": 5.0}}
ROWS = ["ins", "mems", "paper", "firenav"]


def _ekf_params(pipeline: str, component: str) -> dict:
    """The pdr_ekf parameters of a bundled pipeline (one home for each configuration)."""
    spec = yaml.safe_load((PIPES / pipeline).read_text())
    (c,) = [e for e in spec["estimators"] if e["id"] == component]
    return {k: v for k, v in c.items() if k not in ("id", "plugin", "input")}


def _set(d: dict, dotted: str, value) -> None:
    keys = dotted.split(".")
    for k in keys[:-1]:
        d = d.setdefault(k, {})
    d[keys[-1]] = value


def pipeline_text(scenario: str, seed: int, variants: dict[str, dict]) -> str:
    paper_scenario = scenario in ("rfid_route", "rfid_teams")
    ins = CALIBRATED if paper_scenario else {}
    firenav = _ekf_params("rfid-ekf.yaml" if paper_scenario else "rfid-ekf-field.yaml", "ekf")
    tags = ["rfid.detections", "rfid.deployments"]
    ekfs = {"mems": ({"input": "zins.odometry"}, _ekf_params("rfid-mems-baseline.yaml", "mems")),
            "paper": ({"input": ["zins.odometry", *tags]},
                      _ekf_params("rfid-ekf-as-published.yaml", "ekf")),
            "firenav": ({"input": ["zins.odometry", *tags]}, firenav)}
    for name, overrides in variants.items():
        p = copy.deepcopy(firenav)
        for k, v in overrides.items():
            _set(p, k, v)
        ekfs[name] = ({"input": ["zins.odometry", *tags]}, p)
    p = {
        "name": "bench-rfid-report",
        "sources": [{"id": "sim", "plugin": "simulator", "scenario": scenario, "seed": seed}],
        "sensors": [{"id": "imu", "plugin": "foot_imu", "input": "sim.imu"},
                    {"id": "rfid", "plugin": "rfid_reader", "input": ["sim.rfid", "sim.tags"]}],
        "estimators": [
            {"id": "zins", "plugin": "zupt_ins", "input": "imu.imu", **ins},
            {"id": "ins", "plugin": "dead_reckoning", "input": ["zins.odometry", "sim.truth"],
             "start": {"mode": "truth"}},
            *({"id": name, "plugin": "pdr_ekf", **inp, **params}
              for name, (inp, params) in ekfs.items())],
        "sinks": []}
    return yaml.safe_dump(p, sort_keys=False)


class Tally:
    """Per row: errors at the reads, per-run figures."""

    def __init__(self):
        self.reads = defaultdict(list)          # row -> errors at reads [m]
        self.runs = defaultdict(list)           # row -> per (run, agent) dict

    def add(self, result, reads: dict[str, list[float]], rows: list[str]) -> None:
        levels = np.array([f.z for f in result.building.floors])
        for row in rows:
            per_run = {"h2": [], "n": 0, "floor": [], "m2": [], "troff": [], "trusted": []}
            for agent, track in result.tracks.get(f"{row}.pose", {}).items():
                err = track_errors(track, result.truth[agent], levels)
                if not len(err.t):
                    continue
                for tr in reads.get(agent, []):
                    k = np.flatnonzero(err.t <= tr)
                    if len(k):
                        self.reads[row].append(float(err.horizontal[k[-1]]))
                integ = integrity_figures(err)
                per_run["h2"].append(err.horizontal ** 2)
                per_run["floor"].append(err.floor_ok[np.isfinite(err.floor_ok)])
                per_run["m2"].append(err.mahalanobis2[np.isfinite(err.mahalanobis2)])
                per_run["troff"].append(integ["trusted_off_fraction"])
                per_run["trusted"].append(integ["trusted_fraction"])
            h2 = np.concatenate(per_run["h2"])
            m2 = np.concatenate(per_run["m2"])
            self.runs[row].append({
                "rmse": float(np.sqrt(h2.mean())), "h2": h2,
                "floor": np.concatenate(per_run["floor"]),
                "m2": m2,
                "ell95": float(np.mean(m2 <= 5.991)) if m2.size else float("nan"),
                "troff_max_agent": float(max(per_run["troff"])),
                "trusted": float(np.mean(per_run["trusted"]))})

    def row(self, row: str) -> dict:
        runs = self.runs[row]
        rm = np.array([r["rmse"] for r in runs])
        ins = np.array([r["rmse"] for r in self.runs["ins"]])
        reads = np.array(self.reads[row])
        m2 = np.concatenate([r["m2"] for r in runs])
        h2 = np.concatenate([r["h2"] for r in runs])
        ins_h2 = np.concatenate([r["h2"] for r in self.runs["ins"]])
        return {
            "runs": len(runs), "reads": len(reads),
            "reads_mean_m": float(reads.mean()) if len(reads) else None,
            "reads_std_m": float(reads.std()) if len(reads) else None,
            "rmse_pooled_m": float(np.sqrt(h2.mean())),
            "rmse_runs_min_median_max": [float(rm.min()), float(np.median(rm)), float(rm.max())],
            "beats_ins_runs": float(np.mean(rm < ins)),
            "rmse_vs_ins": float(1.0 - np.sqrt(h2.mean()) / np.sqrt(ins_h2.mean())),
            "floor": float(np.concatenate([r["floor"] for r in runs]).mean()),
            "ell95_pooled": float(np.mean(m2 <= 5.991)) if m2.size else None,
            "ell95_min_run": float(min(r["ell95"] for r in runs)),
            "ell95_runs": [float(r["ell95"]) for r in runs],
            "nees_pooled": float(m2.mean()) if m2.size else None,
            "trusted_off_max_run": float(max(r["troff_max_agent"] for r in runs)),
            "trusted_mean": float(np.mean([r["trusted"] for r in runs])),
        }


def run_seed(scenario: str, seed: int, variants: dict, tally: Tally) -> float:
    spec = load_pipeline_text(pipeline_text(scenario, seed, variants),
                              file=f"<bench-rfid-report {scenario} {seed}>")
    t0 = time.monotonic()
    result, seen = run_tapped(spec, TAG_STREAMS)
    if result.faults:
        print(f"  seed {seed}: {len(result.faults)} faults: {result.faults[0]}", file=sys.stderr)
    tally.add(result, tag_times(seen), ROWS + list(variants))
    return time.monotonic() - t0


def parse_variant(text: str) -> tuple[str, dict]:
    name, _, rest = text.partition("=")
    out = {}
    for item in rest.split(","):
        k, _, v = item.partition("=")
        out[k] = yaml.safe_load(v)
    return name, out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenario", help="rfid_route, field_rfid_uncalibrated, ...")
    ap.add_argument("--seeds", default="1000-1019", help="A-B or a,b (default: report seeds)")
    ap.add_argument("--variant", action="append", default=[], help="NAME=KEY=VALUE[,KEY=VALUE]")
    ap.add_argument("--json", type=Path, help="write the figures as JSON")
    args = ap.parse_args(argv)
    seeds = parse_seeds(args.seeds)
    variants = dict(parse_variant(v) for v in args.variant)
    tally = Tally()
    for seed in seeds:
        wall = run_seed(args.scenario, seed, variants, tally)
        print(f"seed {seed}: {wall:.0f} s", file=sys.stderr, flush=True)
    out = {row: tally.row(row) for row in ROWS + list(variants)}
    print(f"\n{args.scenario}, seeds {seeds[0]}-{seeds[-1]} ({len(seeds)} runs; every agent)")
    print("| row | at the tag reads: mean / std [m] | RMSE pooled [m] | RMSE per run min / median / "
          "max | beats INS alone (runs) | RMSE vs INS alone | floor | 95 % ellipse pooled (worst "
          "run) | trusted while > 3 m off, worst run |")
    print("|---|---|---|---|---|---|---|---|---|")
    for row, r in out.items():
        lo, med, hi = r["rmse_runs_min_median_max"]
        reads = (f"{r['reads_mean_m']:.2f} / {r['reads_std_m']:.2f}" if r["reads_mean_m"]
                 is not None else "-")
        print(f"| {row} | {reads} | {r['rmse_pooled_m']:.2f} | {lo:.2f} / {med:.2f} / {hi:.2f} | "
              f"{100 * r['beats_ins_runs']:.0f} % | {100 * r['rmse_vs_ins']:+.0f} % | "
              f"{100 * r['floor']:.1f} % | {100 * (r['ell95_pooled'] or 0):.1f} % "
              f"({100 * r['ell95_min_run']:.0f} %) | {100 * r['trusted_off_max_run']:.1f} % |")
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps({"scenario": args.scenario, "seeds": [seeds[0], seeds[-1]],
                                         "rows": out}, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
