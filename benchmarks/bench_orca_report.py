"""The ORCA report rows: INS alone, ORCA as published and firenav's pipeline on the same runs.

For each scenario (default: the corridor tests I-III and ``field_corridor_run``) and
each pipeline every seed is run once and measured twice: at the check points (the
ORCA paper's eq. 10 RMSE and largest error) and over every pose (integrity: 95 %
ellipse containment, NEES, trusted, trusted while more than 3 m off). Printed per row:
pooled check-point RMSE with the runs' min / median / max, the largest error, runs
better than INS alone on the same seed, the pooled change against INS alone, the
integrity figures (pooled; worst run), the track's wall crossings (runs with any) and
the resets (straight, by way of doors, refused) the run counted.

Run: ``.venv/bin/python benchmarks/bench_orca_report.py --seeds 2000-2009,2020-2029
[--scenarios orca_test1,field_corridor_run] [--rows ins,published,firenav]
[--json out.json]`` (about 3 s per run and row on one free core).
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from firenav_framework.evaluation.runs import _measure, assemble, plan_evaluation
from firenav_framework.evaluation.seeds import parse_seeds
from firenav_framework.pipeline import load_pipeline
from firenav_framework.runner import run_pipeline

ROOT = Path(__file__).resolve().parents[1]
ROWS = {"ins": ("INS alone", ROOT / "pipelines" / "ins-baseline.yaml"),
        "published": ("ORCA as published",
                      ROOT / "pipelines" / "orca-map-matching-as-published.yaml"),
        "firenav": ("firenav", ROOT / "pipelines" / "orca-map-matching.yaml")}
SCENARIOS = ("orca_test1", "orca_test2", "orca_test3", "field_corridor_run")
COUNTS = ("orca_reset", "orca_reset_via_door", "orca_reset_refused")


def measure(path: Path, scenario: str, seeds: list[int], overrides: list[str]) -> dict:
    """One row: every seed run once, measured at the check points and densely."""
    plans = {mode: plan_evaluation(path, scenario=scenario, seeds=seeds, overrides=overrides,
                                   truth_mode=mode) for mode in ("checkpoints", "dense")}
    measured = {mode: [] for mode in plans}
    crossings, counts = [], {k: 0 for k in COUNTS}
    for i, run in enumerate(plans["dense"].runs):
        result = run_pipeline(load_pipeline(run.pipeline, list(run.overrides)))
        for mode, plan in plans.items():
            r = plan.runs[i]
            measured[mode].append(_measure(result, r.seed, r.stream, r.truth_mode, r.align,
                                           r.bound_m, r.sim_id, 0.0))
        n = 0
        for agent, track in result.tracks.get(run.stream, {}).items():
            floor = result.building.floors[0]
            n += int(floor.crosses_wall(track.position[:-1, :2], track.position[1:, :2]).sum())
        crossings.append(n)
        for name, c in result.stats.counts.items():
            for k in COUNTS:
                counts[k] += int(c.get(k, 0))
    ck = assemble(plans["checkpoints"], measured["checkpoints"])
    dense = assemble(plans["dense"], measured["dense"])
    per_run = [r.figures.rmse_m for r in ck.runs]
    worst = lambda key, fn: fn(getattr(r.figures, key) for r in dense.runs)  # noqa: E731
    return {"rmse": ck.overall.rmse_m, "runs": per_run, "max": ck.overall.max_m,
            "ellipse": dense.overall.ellipse95_containment,
            "ellipse_worst": worst("ellipse95_containment", min),
            "ellipse_runs": [r.figures.ellipse95_containment for r in dense.runs],
            "nees_runs": [r.figures.nees_xy for r in dense.runs],
            "nees": dense.overall.nees_xy, "trusted": dense.overall.trusted_fraction,
            "trusted_worst": worst("trusted_fraction", min),
            "off": dense.overall.trusted_off_fraction,
            "off_worst": worst("trusted_off_fraction", max),
            "dense_rmse": dense.overall.rmse_m, "crossings": crossings, **counts}


def line(scenario: str, name: str, row: dict, ins: dict | None) -> str:
    runs = np.array(row["runs"])
    better, gain = "", ""
    if ins is not None:
        better = f"{int(np.sum(runs < np.array(ins['runs'])))}/{len(runs)}"
        gain = f"{100 * (1 - row['rmse'] / ins['rmse']):+.0f} %"
    cross = row["crossings"]
    return (f"| {scenario} | {name} | {row['rmse']:.2f} ({runs.min():.2f} / "
            f"{np.median(runs):.2f} / {runs.max():.2f}) | {row['max']:.2f} | {better} | {gain} "
            f"| {row['ellipse']:.3f} ({row['ellipse_worst']:.2f}; "
            f"{sum(e >= 0.9 for e in row['ellipse_runs'])}/{len(runs)} runs >= 0.90) "
            f"| {row['nees']:.2f} "
            f"| {row['trusted']:.3f} ({row['trusted_worst']:.2f}) | {row['off']:.3f} "
            f"({row['off_worst']:.3f}) | {sum(cross)} in {sum(c > 0 for c in cross)} "
            f"| {row['orca_reset']} / {row['orca_reset_via_door']} / {row['orca_reset_refused']} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="2000-2019")
    ap.add_argument("--scenarios", default=",".join(SCENARIOS))
    ap.add_argument("--rows", default=",".join(ROWS))
    ap.add_argument("--set", action="append", default=[], help="override for the firenav row")
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    seeds = parse_seeds(args.seeds)
    out: dict = {}
    print("| scenario | row | check-point RMSE [m] pooled (runs min / median / max) | max [m] "
          "| runs better than INS alone | pooled RMSE vs INS "
          "| 95 % ellipse (worst run; runs >= 0.90) "
          "| NEES | trusted (least run) | trusted while > 3 m off (worst run) "
          "| wall crossings (runs) | resets / via door / refused |")
    print("|" + "---|" * 12)
    for scenario in args.scenarios.split(","):
        ins = None
        for key in args.rows.split(","):
            name, path = ROWS[key]
            row = measure(path, scenario, seeds, args.set if key == "firenav" else [])
            out[f"{scenario}/{key}"] = row
            print(line(scenario, name, row, None if key == "ins" else ins), flush=True)
            if key == "ins":
                ins = row
    if args.json:
        args.json.write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
