"""ORCA + UWB alone on the ``incident`` scenario: per firefighter, the integrity figures of
the estimator ``mm`` of ``pipelines/incident.yaml`` (the input team_fusion fuses), beside
INS alone (``dr``) on the same runs.

Only the INS, the UWB sensor, ``dr`` and ``mm`` are run (the incident's other methods and
team_fusion are left out: a run is a 20-30 min incident, minutes of CPU):

    python benchmarks/bench_orca_incident.py --seeds 3000-3009 --json out/orca-incident.json

Figures per firefighter pooled over the seeds: horizontal RMSE [m], the 95 % ellipse
containment (pooled; worst run), NEES, the share trusted and the share trusted while more
than 3 m off (pooled; worst run); then each run trusted while more than 3 m off for more
than 2 % of its poses, and with ``--json`` every run's figures (key ``runs``). Seeds run one
after the other in one process.
"""
from __future__ import annotations

import argparse
import json
import pickle
import sys
import tempfile
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
PIPELINE = ROOT / "pipelines" / "incident.yaml"
KEEP = {"ins", "dr", "mm"}


def orca_pipeline(path: Path = PIPELINE) -> dict:
    """``pipelines/incident.yaml`` cut down to the INS, UWB, ``dr`` and ``mm``, no sinks,
    no watchdog."""
    spec = yaml.safe_load(path.read_text())
    spec["sensors"] = [s for s in spec["sensors"] if s["id"] in {"imu", "uwb"}]
    spec["estimators"] = [e for e in spec["estimators"] if e["id"] in KEEP]
    spec["sinks"] = []
    spec["watchdog"] = 0      # figures, not latency: a loaded machine must not cut a run
    return spec


def run_seed(pipeline: str, seed: int, overrides: tuple[str, ...] = ()) -> dict:
    """The TrackErrors of ``dr`` and ``mm`` per firefighter for one seed, the pipeline
    with ``overrides`` (``key.path=value``, as ``firenav run --set``)."""
    from firenav_framework.evaluation.metrics import track_errors
    from firenav_framework.pipeline import load_pipeline
    from firenav_framework.runner import run_pipeline
    spec = load_pipeline(pipeline, [f"sources.sim.seed={seed}", *overrides])
    with tempfile.TemporaryDirectory(prefix="bench-orca-incident-") as out:
        result = run_pipeline(spec, output_dir=Path(out))
    levels = np.array([f.z for f in result.building.floors])
    errors = {}
    for comp in ("dr", "mm"):
        for agent, tr in result.tracks.get(f"{comp}.pose", {}).items():
            if agent in result.truth:
                errors[(comp, agent)] = track_errors(tr, result.truth[agent], levels)
    return errors


def row(errs: list) -> dict:
    """Pooled and worst-run integrity figures of one firefighter's runs."""
    from firenav_framework.evaluation.metrics import pooled_metrics
    pooled = pooled_metrics(errs)
    ellipse = [float(np.nanmean(e.mahalanobis2 <= 5.991)) for e in errs]
    off = [float(np.mean(e.trusted & (e.horizontal > 3.0))) for e in errs]
    n = sum(len(e.horizontal) for e in errs)
    return {"runs": len(errs), "rmse_m": pooled.rmse_m, "ellipse95": pooled.ellipse95_containment,
            "ellipse95_worst": min(ellipse), "nees_xy": pooled.nees_xy,
            "trusted": pooled.trusted_fraction,
            "trusted_off": sum(o * len(e.horizontal) for o, e in zip(off, errs)) / n,
            "trusted_off_worst": max(off)}


def main(argv: list[str] | None = None) -> int:
    from firenav_framework.evaluation.seeds import parse_seeds
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="3000-3009")
    ap.add_argument("--json", default=None)
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="pipeline override, e.g. estimators.mm.drift.correction_doubt=0")
    ap.add_argument("--dump", default=None,
                    help="folder to pickle each seed's TrackErrors into (for diagnosis)")
    a = ap.parse_args(argv)
    seeds = parse_seeds(a.seeds)
    runs = {}
    with tempfile.TemporaryDirectory(prefix="bench-orca-incident-pipe-") as tmp:
        path = Path(tmp) / "incident-orca.yaml"
        path.write_text(yaml.safe_dump(orca_pipeline()))
        for s in seeds:
            runs[s] = run_seed(str(path), s, tuple(a.set))
            if a.dump:
                Path(a.dump).mkdir(parents=True, exist_ok=True)
                (Path(a.dump) / f"seed{s}.pkl").write_bytes(pickle.dumps(runs[s]))
            print(f"seed {s} done", file=sys.stderr, flush=True)
    agents = sorted({k[1] for r in runs.values() for k in r})
    rows = []
    print(f"incident, ORCA + UWB alone, seeds {a.seeds} ({len(runs)} runs)"
          f"{''.join(' --set ' + o for o in a.set)}\n")
    print("| firefighter | row | RMSE [m] | 95 % ellipse (worst run) | NEES | trusted "
          "| trusted while > 3 m off (worst run) |\n|---|---|---|---|---|---|---|")
    for agent in agents:
        for comp, name in (("dr", "INS alone"), ("mm", "ORCA + UWB")):
            errs = [r[(comp, agent)] for r in runs.values() if (comp, agent) in r]
            if not errs:
                continue
            r = {"agent": agent, "component": comp, **row(errs)}
            rows.append(r)
            print(f"| {agent} | {name} | {r['rmse_m']:.2f} | {r['ellipse95']:.3f} "
                  f"({r['ellipse95_worst']:.2f}) | {r['nees_xy']:.2f} | {r['trusted']:.3f} | "
                  f"{r['trusted_off']:.3f} ({r['trusted_off_worst']:.3f}) |")
    per_run = [{"seed": s, "agent": agent, "component": comp,
                "rmse_m": float(np.sqrt(np.mean(e.horizontal ** 2))),
                "trusted": float(np.mean(e.trusted)),
                "trusted_off": float(np.mean(e.trusted & (e.horizontal > 3.0)))}
               for s, r in runs.items() for (comp, agent), e in sorted(r.items())]
    print("\nruns trusted while > 3 m off for more than 2 % of their poses:")
    for p in per_run:
        if p["trusted_off"] > 0.02:
            print(f"  seed {p['seed']} {p['agent']} {p['component']}: "
                  f"{p['trusted_off']:.3f} (RMSE {p['rmse_m']:.2f} m)")
    if a.json:
        Path(a.json).parent.mkdir(parents=True, exist_ok=True)
        Path(a.json).write_text(json.dumps({"seeds": seeds, "rows": rows, "runs": per_run},
                                           indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
