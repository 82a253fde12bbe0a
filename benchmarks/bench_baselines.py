"""INS alone on every bundled scenario (paper and field families), beside the papers' own.

    .venv/bin/python benchmarks/bench_baselines.py                     # report seeds 1000-1019
    .venv/bin/python benchmarks/bench_baselines.py --seeds 100-139     # the tuning seeds
    .venv/bin/python benchmarks/bench_baselines.py field_office_large orca_test1 --json out.json

Each scenario runs through one INS-alone pipeline: simulator -> foot_imu (the scenario's
device axes to FLU) -> zupt_ins with its defaults (no still-start gyro calibration) ->
dead_reckoning with no constraint, aligned with the truth at its first pose (what a
GNSS fix at the door would give: what is left is the sensors' and the INS's drift). The
IMUs have the scenarios' own errors: as worn unless a scenario says otherwise.

The figure beside each paper's is measured the way that paper did:

* ORCA tests I-III (orca-map-matching Tables 2/3) and the field corridor run: RMSE and
  largest error at the marked stops (checkpoints);
* breadcrumb loop (breadcrumb-gen-rmg Sec. V-A: INS alone "more than 35 m" off after
  400 m) and the other breadcrumb scenarios: the error where each firefighter ends;
* RFID route (rfid-mems-ekf: MEMS alone 19.3 m mean, 9.8 m std): the error at each tag
  read (the reader's detections);
* ZUPT extension long trial ("several metres" for plain ZUPT after ten minutes) and the
  field's ten minutes over three storeys: the error at the end, horizontal and vertical;
* search-pattern data sets (the paper reports no INS-alone figure; its walls-only
  particle filter: about 4 m) and the other searches: the RMSE over the whole track.

The real-data twin ``indoor_walk`` is measured against the real walks by
``benchmarks/bench_sim_realism.py`` (their own metric: footfalls after a 5-step fit).

``--zupt-extension`` gives the ZUPT-extension paper's own row instead ("Long trial":
within 5 m laterally and 2 m in height after ten minutes) on ``zupt_multifloor`` and
``field_multifloor_long``, on the same runs: plain ZUPT (the extension off: no height
correction, no retrospective correction), the extension as published
(``pipelines/zupt-extension-as-published.yaml``) and firenav's bundled INS-alone pipeline
(``pipelines/ins-baseline.yaml``: zupt_ins defaults and the gyro bias from the still
start); the end error horizontal and vertical and how many runs end inside
the paper's 5 m / 2 m.

Per row the main figure's mean over the runs (every agent of every seed) and its spread
(min / median / max). Nothing here is tuned; the table goes to stdout (markdown) and with
--json to a file; docs/scenarios.md quotes the report seeds.
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from firenav_framework.evaluation import evaluate  # noqa: E402
from firenav_framework.evaluation.checkpoints import Checkpoints, checkpoint_errors  # noqa: E402
from firenav_framework.evaluation.seeds import parse_seeds  # noqa: E402
from firenav_framework.simulator import load_scenario, simulate  # noqa: E402


@dataclass
class Row:
    scenario: str
    paper: str               # what the paper reports for INS/MEMS alone
    measure: str             # checkpoints | end | tag_reads | dense


ROWS = [
    Row("orca_test1", "RMSE 3.63, max 4.16 at the stops", "checkpoints"),
    Row("orca_test2", "RMSE 3.26, max 3.89", "checkpoints"),
    Row("orca_test3", "RMSE 5.59, max 7.06", "checkpoints"),
    Row("breadcrumb_loop", "end > 35 after 400 m", "end"),
    Row("breadcrumb_fire", "-", "end"),
    Row("rfid_route", "mean 19.3, std 9.8 at the tags", "tag_reads"),
    Row("rfid_teams", "(as rfid_route)", "tag_reads"),
    Row("zupt_multifloor", "plain ZUPT: several m after 10 min", "end"),
    Row("search_flat_right", "- (walls-only PF: ~4)", "dense"),
    Row("search_flat_left", "- (walls-only PF: ~4)", "dense"),
    Row("search_area250", "- (walls-only PF: ~4)", "dense"),
    Row("demo", "-", "dense"),
    Row("field_flat_wrong_plan", "-", "dense"),
    Row("field_flat_consumer", "-", "dense"),
    Row("field_crawl_search", "-", "dense"),
    Row("field_office_large", "-", "dense"),
    Row("field_apartments", "-", "dense"),
    Row("field_corridor_run", "(ORCA: RMSE 3.3-5.6)", "checkpoints"),
    Row("field_rfid_uncalibrated", "(RFID: mean 19.3)", "tag_reads"),
    Row("field_breadcrumb_fire", "-", "end"),
    Row("field_breadcrumb_loop", "(breadcrumb: end > 35)", "end"),
    Row("field_multifloor_long", "(ZUPT ext.: several m)", "end"),
]

PIPELINE = """\
name: ins_alone_{scenario}
sources:
  - {{id: sim, plugin: simulator, scenario: {scenario}, seed: 0}}
sensors:
  - {{id: imu, plugin: foot_imu, input: sim.imu, axes: {axes}}}
estimators:
  - {{id: ins, plugin: zupt_ins, input: imu.imu}}
  - {{id: dr, plugin: dead_reckoning, input: [ins.odometry, sim.truth], start: {{mode: truth}}}}
"""

#: foot_imu ``axes`` (device axis that becomes FLU x, y, z) per device frame.
AXES = {"FLU": ["x", "y", "z"], "FRD": ["x", "-y", "-z"]}


def _tag_reads(sim_result, agent: str) -> Checkpoints | None:
    """Where (and when) the agent's reader detected a tag, as checkpoints."""
    t = np.array([m.t for m in sim_result.messages.get("rfid", []) if m.agent == agent])
    if not len(t):
        return None
    tr = sim_result.truth[agent]
    pos = np.column_stack([np.interp(t, tr.t, tr.position[:, i]) for i in range(3)])
    return Checkpoints(agent, t, pos, np.asarray(sim_result.world.floor_of_z(pos[:, 2])))


def measure(row: Row, seeds: list[int], work: Path) -> dict:
    sc = load_scenario(row.scenario)
    frames = {a.sensors.imu.axes for a in sc.model.agents if a.sensors.imu is not None}
    if len(frames) != 1:
        raise SystemExit(f"{row.scenario}: agents with different IMU axes {frames}")
    path = work / f"{row.scenario}.yaml"
    path.write_text(PIPELINE.format(scenario=row.scenario, axes=json.dumps(AXES[frames.pop()])))
    mode = "checkpoints" if row.measure == "checkpoints" else "dense"
    t0 = time.monotonic()
    ev = evaluate(path, seeds=seeds, truth_mode=mode)
    main, second = [], []
    for run in ev.runs:
        sim = simulate(row.scenario, run.seed) if row.measure == "tag_reads" else None
        for agent, err in run.errors.items():
            h = err.horizontal
            if row.measure == "checkpoints":
                main.append(float(np.sqrt(np.mean(h ** 2))))
                second.append(float(h.max()))
            elif row.measure == "end":
                main.append(float(h[-1]))
                second.append(float(abs(err.vertical[-1])) if err.vertical.size else np.nan)
            elif row.measure == "tag_reads":
                cps = _tag_reads(sim, agent)
                if cps is None:
                    continue
                e, _ = checkpoint_errors(run.tracks[agent], cps)
                main.extend(e.horizontal.tolist())
            else:
                main.append(float(np.sqrt(np.mean(h ** 2))))
                second.append(100.0 * float(h.mean()) / err.distance_m)
    a = np.array(main, float)
    b = np.array(second, float)
    grades = sorted({ag.sensors.imu.grade for ag in sc.model.agents if ag.sensors.imu})
    return {"scenario": row.scenario, "family": sc.model.family, "grades": grades,
            "paper": row.paper, "measure": row.measure, "seeds": [seeds[0], seeds[-1]],
            "runs": len(ev.runs), "values": len(a), "wall_s": round(time.monotonic() - t0, 1),
            "mean": float(a.mean()), "min": float(a.min()), "median": float(np.median(a)),
            "max": float(a.max()), "std": float(a.std()),
            "second_mean": float(np.nanmean(b)) if b.size else None,
            "second_max": float(np.nanmax(b)) if b.size else None}


ZUPT_EXTENSION_SCENARIOS = ("zupt_multifloor", "field_multifloor_long")
AS_PUBLISHED = REPO / "pipelines" / "zupt-extension-as-published.yaml"
INS_BASELINE = REPO / "pipelines" / "ins-baseline.yaml"
#: the paper's extension (velocity and height corrections) switched off: plain ZUPT
EXTENSION_OFF = ["estimators.ins.height.correction=false",
                 "estimators.ins.outputs.retrospective_correction=false"]


def end_errors(pipeline: Path, scenario: str, seeds: list[int], overrides=()) -> dict:
    """End error [m] horizontal and |vertical| of every agent of every seed."""
    ev = evaluate(pipeline, scenario=scenario, seeds=seeds, overrides=list(overrides),
                  truth_mode="dense")
    h, v = [], []
    for run in ev.runs:
        for err in run.errors.values():
            h.append(float(err.horizontal[-1]))
            v.append(float(abs(err.vertical[-1])) if err.vertical.size else np.nan)
    return {"horizontal": h, "vertical": v}


def spread(x: list[float]) -> str:
    a = np.asarray(x, float)
    return f"{a.mean():.2f} [{a.min():.2f} / {np.median(a):.2f} / {a.max():.2f}]"


def zupt_extension(seeds: list[int], out_json: Path | None) -> None:
    """The ZUPT-extension paper's row: extension off, as published, firenav's INS."""
    print(f"ZUPT extension, end error after the walk (paper: within 5 m laterally, 2 m in "
          f"height after ten minutes), seeds {seeds[0]}-{seeds[-1]}; mean [min / median / "
          "max] over the runs\n")
    print("| scenario | method | end error horizontal [m] | end error height [m] | "
          "runs within 5 m / 2 m |")
    print("|---|---|---|---|---|")
    results = []
    for scenario in ZUPT_EXTENSION_SCENARIOS:
        for method, path, over in (("plain ZUPT (extension off)", AS_PUBLISHED, EXTENSION_OFF),
                                   ("ZUPT extension as published", AS_PUBLISHED, ()),
                                   ("firenav ins-baseline", INS_BASELINE, ())):
            e = end_errors(path, scenario, seeds, over)
            inside = sum(h <= 5.0 and v <= 2.0 for h, v in zip(e["horizontal"], e["vertical"]))
            print(f"| {scenario} | {method} | {spread(e['horizontal'])} | "
                  f"{spread(e['vertical'])} | {inside} of {len(e['horizontal'])} |", flush=True)
            results.append({"scenario": scenario, "method": method, "seeds": seeds, **e})
            if out_json:
                out_json.write_text(json.dumps(results, indent=1) + "\n")


FIGURE = {"checkpoints": "RMSE at the stops [m] (max)", "end": "end error [m] (height)",
          "tag_reads": "error at the tag reads [m] (std)",
          "dense": "RMSE [m] (mean % of distance)"}


def cell(m: dict) -> str:
    second = ""
    if m["measure"] == "checkpoints":
        second = f"; max {m['second_mean']:.1f}"
    elif m["measure"] == "end" and m["second_mean"] is not None:
        second = f"; height {m['second_mean']:.1f}"
    elif m["measure"] == "tag_reads":
        second = f"; std {m['std']:.1f}"
    elif m["measure"] == "dense":
        second = f"; {m['second_mean']:.1f} % of distance"
    return (f"{m['mean']:.2f} [{m['min']:.2f} / {m['median']:.2f} / {m['max']:.2f}]{second}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scenarios", nargs="*", help="subset of scenarios (default all)")
    ap.add_argument("--seeds", default="1000-1019", help="A-B or a,b,c (default: the "
                    "report seeds 1000-1019)")
    ap.add_argument("--json", type=Path, help="write the figures to this file")
    ap.add_argument("--zupt-extension", action="store_true", help="the ZUPT-extension "
                    "paper's row: extension off / as published / firenav's INS")
    args = ap.parse_args()
    if args.zupt_extension:
        zupt_extension(parse_seeds(args.seeds), args.json)
        return 0
    rows = [r for r in ROWS if not args.scenarios or r.scenario in args.scenarios]
    seeds = parse_seeds(args.seeds)
    results = []
    print(f"INS alone (zupt_ins defaults + dead_reckoning aligned with the truth), seeds "
          f"{seeds[0]}-{seeds[-1]}; mean [min / median / max] over the runs, metres unless "
          "stated\n")
    print("| scenario | family | IMU (as worn) | paper, INS/MEMS alone | figure | INS alone |")
    print("|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for row in rows:
            m = measure(row, seeds, Path(tmp))
            results.append(m)
            print(f"| {row.scenario} | {m['family']} | {', '.join(m['grades'])} | {row.paper} | "
                  f"{FIGURE[row.measure]} | {cell(m)} |", flush=True)
            if args.json:
                args.json.write_text(json.dumps(results, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
