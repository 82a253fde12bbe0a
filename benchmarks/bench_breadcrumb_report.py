"""The breadcrumb rows of the report: PDR alone, GEN as published, firenav's GEN, same runs.

Per seed one simulation runs ``pipelines/breadcrumb-gen.yaml`` with a second
``breadcrumb_gen`` beside it configured as ``pipelines/breadcrumb-gen-as-published.yaml``
(the paper's rules and parameters), both fed by the same foot INS and radio: the three
rows are on exactly the same runs. Figures per track (every agent of every seed):

* the paper's metrics (breadcrumb paper §V-A): mean and maximum error over the true
  distance [%], and the error at the end of the trace [m] (Fig. 9b: "the location error
  at the end of the trace is more than 35 meters" for PDR alone);
* RMSE [m], pooled, and the share of runs in which the row beats PDR alone (RMSE);
* integrity (firenav_framework.evaluation.metrics): truth inside the 95 % ellipse,
  trusted while more than 3 m off (worst run), trusted share.

Spread: min / median / max over tracks. Seeds: ``--seeds report`` (1000-1019) for reported
figures, ``tuning`` (100-139) for choosing defaults.

Run: ``.venv/bin/python benchmarks/bench_breadcrumb_report.py --scenario field_breadcrumb_loop
[--seeds report] [--workers 2] [--entrance] [--jsonl out.jsonl]`` (``--table --jsonl
out.jsonl`` prints the table of the seeds done so far).
"""
from __future__ import annotations

import argparse
import json
import os
import tempfile
from multiprocessing import get_context
from pathlib import Path

import numpy as np
import yaml

# plugin imports on a loaded machine can take longer than the 30 s default
os.environ.setdefault("FIRENAV_IMPORT_TIMEOUT", "600")

from firenav_framework.evaluation.metrics import metrics_of, track_errors  # noqa: E402
from firenav_framework.evaluation.seeds import parse_seeds  # noqa: E402
from firenav_framework.pipeline import load_pipeline  # noqa: E402
from firenav_framework.runner import run_pipeline  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
OURS = ROOT / "pipelines" / "breadcrumb-gen.yaml"
PAPER = ROOT / "pipelines" / "breadcrumb-gen-as-published.yaml"
ROWS = (("PDR alone", "pdr.pose"), ("GEN as published", "paper.pose"),
        ("firenav GEN", "gen.pose"))


def combined_pipeline(entrance: bool) -> dict:
    """breadcrumb-gen.yaml plus the as-published estimator as ``paper`` (no sinks)."""
    ours = yaml.safe_load(OURS.read_text())
    paper = yaml.safe_load(PAPER.read_text())
    est = next(e for e in paper["estimators"] if e["plugin"] == "breadcrumb_gen")
    ours["estimators"].append({**est, "id": "paper"})
    ours["sinks"] = []
    ours["watchdog"] = 0          # a loaded machine must not stop a report run
    if entrance:
        pdr = next(e for e in ours["estimators"] if e["id"] == "pdr")
        pdr["start"] = {"mode": "entrance"}
    return ours


def run_seed(job: tuple[int, str, bool, list[str]]) -> dict:
    """Figures of every track of every row on one seed (JSON-ready)."""
    seed, scenario, entrance, overrides = job
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "report.yaml"
        path.write_text(yaml.safe_dump(combined_pipeline(entrance)))
        spec = load_pipeline(path, [f"sources.sim.seed={seed}",
                                    f"sources.sim.scenario={scenario}", *overrides])
        res = run_pipeline(spec, output_dir=Path(tmp))
    out = {}
    for row, stream in ROWS:
        for agent, track in sorted(res.tracks[stream].items()):
            truth = res.truth[agent]
            m = metrics_of(track_errors(track, truth))
            end = float(np.hypot(*(track.position[-1, :2] - truth.position[-1, :2])))
            out.setdefault(row, []).append({"seed": seed, "agent": agent, "end_m": end,
                                            **m.as_dict()})
    return out


def spread(values) -> str:
    v = np.asarray([x for x in values if x is not None], float)
    if not v.size:
        return "-"
    return f"{np.min(v):.2f} / {np.median(v):.2f} / {np.max(v):.2f}"


def fmt(v: float | None) -> str:
    return "-" if v is None else f"{v:.3f}"


def pooled(tracks: list[dict], key: str) -> float | None:
    """A per-sample figure pooled over tracks (weighted by their samples)."""
    got = [(t["n"], t[key]) for t in tracks if t[key] is not None]
    if not got:
        return None
    n = np.array([g[0] for g in got], float)
    v = np.array([g[1] for g in got], float)
    if key == "rmse_m":
        return float(np.sqrt(np.sum(n * v ** 2) / n.sum()))
    return float(np.sum(n * v) / n.sum())


def table(scenario: str, per_seed: list[dict]) -> str:
    rows: dict[str, list] = {}
    for r in per_seed:
        for row, tracks in r.items():
            rows.setdefault(row, []).extend(tracks)
    seeds = sorted({t["seed"] for t in rows["PDR alone"]})
    pdr = {(t["seed"], t["agent"]): t["rmse_m"] for t in rows["PDR alone"]}
    lines = [f"{scenario}, seeds {seeds[0]}-{seeds[-1]} ({len(seeds)} runs, {len(pdr)} "
             "tracks); spread = min / median / max over tracks",
             "| row | mean / distance [%] | max / distance [%] | end error [m] | RMSE [m] "
             "pooled | RMSE per track | beats PDR (RMSE) | in 95 % ellipse | trusted while "
             "> 3 m off (worst track) | trusted |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for row, _ in ROWS:
        tr = rows[row]
        beats = np.mean([t["rmse_m"] < pdr[(t["seed"], t["agent"])] for t in tr])
        off = [t["trusted_off_fraction"] for t in tr if t["trusted_off_fraction"] is not None]
        lines.append(
            f"| {row} | {spread(t['mean_pct_distance'] for t in tr)} | "
            f"{spread(t['max_pct_distance'] for t in tr)} | {spread(t['end_m'] for t in tr)} | "
            f"{pooled(tr, 'rmse_m'):.2f} | {spread(t['rmse_m'] for t in tr)} | {beats:.0%} | "
            f"{fmt(pooled(tr, 'ellipse95_containment'))} | {fmt(max(off, default=None))} | "
            f"{fmt(pooled(tr, 'trusted_fraction'))} |")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="breadcrumb_loop")
    ap.add_argument("--seeds", default="report")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--entrance", action="store_true", help="start at the building's "
                    "entrance (the fire floors) instead of the loop's base-station corner")
    ap.add_argument("--jsonl", default="", help="append each seed's figures here as it "
                    "finishes; with --table only, print the table of such a file")
    ap.add_argument("--table", action="store_true")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="override a value of the combined pipeline (e.g. "
                    "estimators.gen.heading.rate_sigma=0.03; the as-published one is "
                    "estimators.paper)")
    args = ap.parse_args()
    if args.table:
        per_seed = [json.loads(line) for line in Path(args.jsonl).read_text().splitlines()]
        print(table(args.scenario, per_seed))
        return
    seeds = parse_seeds(args.seeds)
    seeds = seeds[:20] if args.seeds == "report" else seeds
    jobs = [(s, args.scenario, args.entrance, args.set) for s in seeds]
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    per_seed = []
    with get_context("spawn").Pool(args.workers) as pool:
        for r in pool.imap_unordered(run_seed, jobs):
            per_seed.append(r)
            if args.jsonl:
                with open(args.jsonl, "a") as f:
                    f.write(json.dumps(r) + "\n")
            print(f"seed {r['PDR alone'][0]['seed']} done", flush=True)
    print(table(args.scenario, per_seed))


if __name__ == "__main__":
    main()
