"""The incident's report tables: per firefighter, INS alone, each single method and
team_fusion on the same runs, and the ablations (no tags, no breadcrumbs, no UWB, no plan,
no barometer).

One run per seed of ``pipelines/incident.yaml`` with the ablations added to it as extra
estimators (so every row of a seed comes from the same simulated data):

* ``team_no_tags``   team_fusion without the RFID EKF's poses;
* ``team_no_bc``     without breadcrumb GEN's poses;
* ``team_no_uwb``    with ``mm_no_uwb`` (ORCA map matching without the anchor) in place of ``mm``
                     (with ``mm``'s input settings);
* ``team_no_plan``   without the plan-based methods (particle filter, ORCA, the RFID EKF,
                     whose tag sites are the plan's doors): INS alone and GEN;
* ``team_no_baro``   without the barometer's height (its floor vote).

    python benchmarks/bench_team_incident.py --seeds 1000-1019 --workers 2 \
        --json out/team-incident.json --runs out/team-incident-runs

``--no-ablations`` runs team_fusion and the single methods only (one team_fusion, no
second ORCA: a run about a third cheaper). ``--record`` keeps, per seed, every message
``team`` received (in order) with the truth; ``--replay`` then computes team_fusion's
rows again from those recordings through the estimator with the pipeline's current
settings (``--set quality.margin=4``-style overrides of team's parameters on top),
without running the methods: the same figures as running the pipeline when the
settings are the same (bit-identical on the short incident).

A GEN row is left out for a firefighter without a radio (its pose is then the odometry
it was given). Figures: pooled horizontal RMSE and p95 [m] over the seeds, the per-run RMSE spread
(min / median / max), the share of runs that beat INS alone (``dr``), floor right,
the 95 % ellipse containment and the worst run's share of poses trusted while > 3 m off.
"""
from __future__ import annotations

import argparse
import copy
import json
import pickle
import sys
import tempfile
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import yaml

from firenav_framework.evaluation.seeds import parse_seeds


ROOT = Path(__file__).resolve().parents[1]
PIPELINE = ROOT / "pipelines" / "incident.yaml"

METHODS = {"dr": "INS alone", "pf": "particle filter", "mm": "ORCA + UWB", "ekf": "RFID EKF",
           "gen": "breadcrumb GEN", "team": "team_fusion"}
ABLATIONS = {"team": "all sources", "team_no_tags": "no tags", "team_no_bc": "no breadcrumbs",
             "team_no_uwb": "no UWB", "team_no_plan": "no plan", "team_no_baro": "no barometer"}


def ablation_pipeline(path: Path = PIPELINE, ablations: bool = True) -> dict:
    """``pipelines/incident.yaml`` with the ablation estimators added (unless not
    ``ablations``) and no sinks."""
    spec = yaml.safe_load(path.read_text())
    spec["sinks"] = []
    if not ablations:
        return spec
    est = spec["estimators"]
    by_id = {e["id"]: e for e in est}
    team = by_id["team"]
    mm = copy.deepcopy(by_id["mm"])
    mm["id"] = "mm_no_uwb"
    mm["constraints"] = [{"id": f"{c['plugin']}_no_uwb", "plugin": c["plugin"]}
                         for c in mm["constraints"] if c["plugin"] != "anchor_range"]
    est.insert(est.index(team), mm)

    def variant(name: str, drop: set[str], add: tuple[str, ...] = ()) -> dict:
        v = copy.deepcopy(team)
        v["id"] = name
        v["input"] = [s for s in team["input"] if s.split(".")[0] not in drop] + list(add)
        if "mm_no_uwb.pose" in add and "mm.pose" in v.get("inputs", {}):
            v["inputs"]["mm_no_uwb.pose"] = v["inputs"]["mm.pose"]   # the same method's settings
        return v

    est += [variant("team_no_tags", {"ekf"}), variant("team_no_bc", {"gen"}),
            variant("team_no_uwb", {"mm"}, ("mm_no_uwb.pose",)),
            variant("team_no_plan", {"pf", "mm", "ekf"}), variant("team_no_baro", {"baro"})]
    return spec


def run_seed(args: tuple[str, int, str | None, bool]) -> dict:
    """Run one seed; the TrackErrors of every pose stream per agent (and, when
    ``record``, what ``team`` received, the truth and the building)."""
    pipeline, seed, scenario, record = args
    from firenav_framework.evaluation.metrics import track_errors
    from firenav_framework.pipeline import load_pipeline
    from firenav_framework.runner import Runner
    over = [f"sources.sim.seed={seed}"]
    if scenario:
        over.append(f"sources.sim.scenario={json.dumps(scenario)}")
    spec = load_pipeline(pipeline, over)
    received: list = []
    with tempfile.TemporaryDirectory(prefix="bench-team-") as out:
        runner = Runner(spec, output_dir=Path(out))
        if record:
            _record_inputs(runner, "team", received)
        result = runner.run()
    levels = np.array([f.z for f in result.building.floors])
    errors = {}
    for stream, tracks in result.tracks.items():
        comp = stream.split(".")[0]
        if not stream.endswith(".pose") or comp not in {**METHODS, **ABLATIONS, "mm_no_uwb": 0}:
            continue
        for agent, tr in tracks.items():
            if agent in result.truth:
                errors[(comp, agent)] = track_errors(tr, result.truth[agent], levels)
    run = {"seed": seed, "errors": errors}
    if record:
        run["recording"] = {"messages": received, "truth": result.truth,
                            "building": result.building}
    return run


def _record_inputs(runner, cid: str, into: list) -> None:
    """Append every ``(stream, message)`` component ``cid`` is handed in the run to ``into``."""
    build = runner.build

    def build_and_tap() -> None:
        build()
        comp = runner.components[cid]
        handle = comp.handle

        def recorded(stream, msg) -> None:
            into.append((stream, msg))
            handle(stream, msg)
        comp.handle = recorded
    runner.build = build_and_tap


def team_params(path: Path = PIPELINE, overrides: list[str] = ()) -> dict:
    """``team``'s parameters in the pipeline, with ``key.sub=value`` overrides (YAML
    values; ``inputs.mm.pose.inflate=2`` sets ``inflate`` of the input ``mm.pose``)."""
    spec = yaml.safe_load(path.read_text())
    team = next(e for e in spec["estimators"] if e["id"] == "team")
    params = {k: v for k, v in team.items() if k not in ("id", "plugin", "input")}
    for expr in overrides:
        key, _, value = expr.partition("=")
        *parents, leaf = key.split(".")
        if parents[:1] == ["inputs"]:               # inputs.<stream with dots>.<field>
            parents = ["inputs", ".".join(parents[1:])]
        node = params
        for k in parents:
            node = node.setdefault(k, {})
        node[leaf] = yaml.safe_load(value)
    return params


def replay(recording: dict, params: dict, comp: str = "team") -> dict:
    """team_fusion with ``params`` on a seed's recorded inputs: TrackErrors per agent,
    keyed ``(comp, agent)``."""
    from firenav_framework.evaluation.metrics import track_errors
    from firenav_framework.testing import Session
    from firenav_framework.tracks import TrackStore
    from firenav_plugins.estimators.team_fusion import TeamFusionEstimator
    rec = Session(TeamFusionEstimator, params, building=recording["building"],
                  ticks=False).run(recording["messages"])
    store = TrackStore()
    for msg in rec.on("pose"):
        store("team.pose", msg)
    truth, building = recording["truth"], recording["building"]
    levels = np.array([f.z for f in building.floors])
    return {(comp, agent): track_errors(tr, truth[agent], levels)
            for agent, tr in store.tracks().get("team.pose", {}).items() if agent in truth}


def rmse(e) -> float:
    return float(np.sqrt(np.mean(e.horizontal ** 2))) if len(e.horizontal) else float("nan")


def row(comp: str, agent: str, runs: list[dict]) -> dict | None:
    from firenav_framework.evaluation.metrics import pooled_metrics
    errs = [r["errors"][(comp, agent)] for r in runs if (comp, agent) in r["errors"]]
    if not errs:
        return None
    base = [r["errors"].get(("dr", agent)) for r in runs if (comp, agent) in r["errors"]]
    if comp == "gen" and all(b is not None and abs(rmse(e) - rmse(b)) < 0.01
                             for e, b in zip(errs, base)):
        return None     # no radio: GEN's pose is the odometry it was given
    if comp == "dr":
        base = []
    pooled = pooled_metrics(errs)
    per_run = np.array([rmse(e) for e in errs])
    beats = [rmse(e) < rmse(b) for e, b in zip(errs, base) if b is not None]
    off = [float(np.mean(e.trusted & (e.horizontal > 3.0))) if len(e.trusted) else 0.0
           for e in errs]
    return {"component": comp, "agent": agent, "runs": len(errs), "rmse_m": pooled.rmse_m,
            "p95_m": pooled.p95_m, "rmse_min": float(per_run.min()),
            "rmse_median": float(np.median(per_run)), "rmse_max": float(per_run.max()),
            "beats_ins": float(np.mean(beats)) if beats else None,
            "floor_accuracy": pooled.floor_accuracy,
            "ellipse95": pooled.ellipse95_containment, "nees_xy": pooled.nees_xy,
            "trusted": pooled.trusted_fraction, "trusted_off_worst": max(off)}


def fmt(v, nd=2, unit="") -> str:
    if v is None:
        return "-"
    if isinstance(v, float):
        return f"{v:.{nd}f}{unit}"
    return f"{v}{unit}"


def table(rows: list[dict], names: dict[str, str]) -> str:
    head = ("| firefighter | pipeline | runs | RMSE [m] | p95 [m] | per-run RMSE min / median / max "
            "| beats INS | floor right | 95 % ellipse | trusted | trusted > 3 m off (worst run) |")
    lines = [head, "|" + "---|" * 11]
    for r in rows:
        lines.append(
            f"| {r['agent']} | {names.get(r['component'], r['component'])} | {r['runs']} | "
            f"{fmt(r['rmse_m'])} | {fmt(r['p95_m'])} | {fmt(r['rmse_min'])} / "
            f"{fmt(r['rmse_median'])} / {fmt(r['rmse_max'])} | "
            f"{fmt(None if r['beats_ins'] is None else 100 * r['beats_ins'], 0, ' %')} | "
            f"{fmt(None if r['floor_accuracy'] is None else 100 * r['floor_accuracy'], 1, ' %')} | "
            f"{fmt(None if r['ellipse95'] is None else 100 * r['ellipse95'], 0, ' %')} | "
            f"{fmt(None if r['trusted'] is None else 100 * r['trusted'], 0, ' %')} | "
            f"{fmt(100 * r['trusted_off_worst'], 1, ' %')} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="1000-1019")
    ap.add_argument("--scenario", default=None, help="another scenario (name or file)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--json", default=None)
    ap.add_argument("--runs", default=None, help="folder keeping each seed's errors "
                    "(a seed already there is not run again)")
    ap.add_argument("--no-ablations", action="store_true", help="team_fusion and the "
                    "single methods only")
    ap.add_argument("--record", action="store_true", help="keep what team received in "
                    "each seed's file (needs --runs)")
    ap.add_argument("--replay", action="store_true", help="team_fusion's rows from the "
                    "recorded seeds in --runs with today's settings (no pipeline run)")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="with --replay: override one of team's parameters")
    a = ap.parse_args(argv)
    if (a.record or a.replay) and not a.runs:
        ap.error("--record and --replay need --runs")
    seeds = parse_seeds(a.seeds)
    keep = Path(a.runs) if a.runs else None
    runs, todo = [], []
    for s in seeds:
        f = keep / f"seed{s}.pkl" if keep else None
        if f is not None and f.exists():
            runs.append(pickle.loads(f.read_bytes()))
        elif a.replay:
            print(f"seed {s}: no recording in {keep}, left out", file=sys.stderr)
        else:
            todo.append(s)
    if a.replay:
        params = team_params(overrides=a.set)
        for r in runs:
            if "recording" not in r:
                ap.error(f"seed {r['seed']} in {keep} was run without --record")
            r["errors"] = {k: v for k, v in r["errors"].items() if k[0] not in ABLATIONS}
            r["errors"].update(replay(r["recording"], params))
    with tempfile.TemporaryDirectory(prefix="bench-team-pipe-") as tmp:
        path = Path(tmp) / "incident-ablations.yaml"
        path.write_text(yaml.safe_dump(ablation_pipeline(ablations=not a.no_ablations)))
        jobs = [(str(path), s, a.scenario, a.record) for s in todo]
        with ProcessPoolExecutor(max(1, a.workers)) as ex:
            for r in ex.map(run_seed, jobs):
                print(f"seed {r['seed']} done", file=sys.stderr, flush=True)
                if keep is not None:
                    keep.mkdir(parents=True, exist_ok=True)
                    (keep / f"seed{r['seed']}.pkl").write_bytes(pickle.dumps(r))
                runs.append(r)
    runs.sort(key=lambda r: r["seed"])
    agents = sorted({k[1] for r in runs for k in r["errors"]})
    main_rows = [x for ag in agents for c in METHODS if (x := row(c, ag, runs))]
    abl_rows = [x for ag in agents for c in ABLATIONS if (x := row(c, ag, runs))]
    print(f"incident, seeds {a.seeds} ({len(runs)} runs), scenario {a.scenario or 'incident'}\n")
    print(table(main_rows, METHODS))
    if any(r["component"] != "team" for r in abl_rows):
        print("\nAblations (team_fusion without one source):\n")
        print(table(abl_rows, ABLATIONS))
    if a.json:
        Path(a.json).parent.mkdir(parents=True, exist_ok=True)
        Path(a.json).write_text(json.dumps({"seeds": seeds, "rows": main_rows,
                                            "ablations": abl_rows}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
