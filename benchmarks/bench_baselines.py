"""INS-alone baselines of every reference scenario, over several seeds, beside the papers.

    .venv/bin/python benchmarks/bench_baselines.py                 # all scenarios, 5 seeds
    .venv/bin/python benchmarks/bench_baselines.py --seeds 10 orca_test1 rfid_route

Each scenario runs through the same INS-alone pipeline: simulator -> foot_imu (the
scenario's device axes to FLU) -> zupt_ins (plugin defaults) -> dead_reckoning with no
constraint, aligned with the true start (IMU position, walking heading: ideal
alignment, what is left is sensor drift). Two variants of the INS:

* ``as cal.``: the sensor as calibrated before the run (factory, or the user's lab
  calibration where the paper says so); the turn-on bias left over drives the drift;
* ``+still``: the INS also takes the gyro bias from the still start (``alignment.gyro_bias``
  over the scenario's first seconds), as foot-INS products do; then only in-run
  instability, the boot's warm-up (thermal drift) and g-sensitivity drive it.

The figure printed beside each paper's number is measured the way the paper did:

* ORCA tests I-III (orca-map-matching Table 2/3): RMSE and max error at the check
  points (the scenario's marked stops), mean over runs;
* breadcrumb loop (breadcrumb-gen-rmg Sec. V-A): error at the end of the 400 m ("more
  than 35 meters") and the mean error;
* RFID route (rfid-mems-ekf, Performance assessment): mean and std of the errors where
  tags were stuck (MEMS alone 19.3 m mean, 9.8 m std);
* ZUPT extension long trial: error at the end of ten minutes, horizontal and vertical;
* search-pattern data sets 1 and 2: INS alone is not reported (its baseline is a
  particle filter); printed for reference;
* indoor_walk: the real-data check - error at every step after a rigid fit on the
  first 5 steps, % of distance, to set beside bench_ins_real_data.py's indoor walks
  (same IMU model, same INS: 0.5-2 %, mean 1.1 %).

Nothing is tuned per seed; every row uses the seeds 0..N-1. The table goes to stdout
and, with --json, to a file (docs/scenarios.md quotes it).
"""
from __future__ import annotations

import argparse
import json
import math
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
from firenav_framework.simulator import load_scenario, simulate  # noqa: E402


@dataclass
class Row:
    scenario: str
    paper: str               # what the paper reports
    measure: str             # how we measure it here


ROWS = [
    Row("orca_test1", "RMSE 3.63 m, max 4.16 m", "checkpoints"),
    Row("orca_test2", "RMSE 3.26 m, max 3.89 m", "checkpoints"),
    Row("orca_test3", "RMSE 5.59 m, max 7.06 m", "checkpoints"),
    Row("breadcrumb_loop", "end > 35 m after 400 m", "end"),
    Row("rfid_route", "mean 19.3 m, std 9.8 m at tags", "tags"),
    Row("zupt_multifloor", "plain ZUPT several m; ext. < 5 m, z < 2 m", "end"),
    Row("search_flat_right", "not reported", "dense"),
    Row("search_flat_left", "not reported", "dense"),
    Row("search_area250", "not reported", "dense"),
    Row("indoor_walk", "real walks (same INS): 0.5-2 %, mean 1.1 %", "steps"),
]

PIPELINE = """\
name: ins_alone_{scenario}
sources:
  - {{id: sim, plugin: simulator, scenario: {scenario}, seed: 0}}
sensors:
  - {{id: imu, plugin: foot_imu, input: sim.imu, axes: {axes}}}
estimators:
  - {{id: ins, plugin: zupt_ins, input: imu.imu,
     alignment: {{gyro_bias: {still}, duration: {align_s}}}}}
  - id: dr
    plugin: dead_reckoning
    input: ins.odometry
    start: {{mode: pose, agents: {poses}}}
"""

#: foot_imu ``axes`` (device axis that becomes FLU x, y, z) per device frame.
AXES = {"FLU": ["x", "y", "z"], "FRD": ["x", "-y", "-z"]}


def start_poses(scenario: str) -> dict[str, dict]:
    """True start of every agent (the same for every seed): the IMU's position and the
    body's heading (dead_reckoning maps the INS's walking direction onto it)."""
    r = simulate(scenario, 0, duration_s=1.0)
    out = {}
    for agent, tr in r.truth.items():
        p, heading = tr.foot.position[0], tr.heading[0]
        out[agent] = {"position": [round(float(v), 6) for v in p],
                      "heading": round(float(heading), 6)}
    return out


def _tag_checkpoints(sim_result, agent: str) -> Checkpoints:
    """Where (and when) the agent stuck its tags, as checkpoints."""
    tags = [v for v in sim_result.tags.values() if v["agent"] == agent]
    tr = sim_result.truth[agent]
    t = np.array([v["t"] for v in tags])
    pos = np.column_stack([np.interp(t, tr.t, tr.position[:, i]) for i in range(3)])
    return Checkpoints(agent, t, pos, np.full(len(t), -1))


def measure(row: Row, seeds: list[int], work: Path, still: bool) -> dict:
    sc = load_scenario(row.scenario)
    cfg = sc.model.agents[0].sensors.imu
    path = work / f"{row.scenario}-{still}.yaml"
    path.write_text(PIPELINE.format(
        scenario=row.scenario, poses=json.dumps(start_poses(row.scenario)),
        axes=json.dumps(AXES[cfg.axes]), still=str(still).lower(),
        align_s=max(0.1, sc.model.agents[0].start.time_s - 1.0)))
    mode = "checkpoints" if row.measure == "checkpoints" else "dense"
    t0 = time.monotonic()
    ev = evaluate(path, seeds=seeds, truth_mode=mode)
    out = {"scenario": row.scenario, "grade": cfg.grade, "still_calibration": still,
           "paper": row.paper, "seeds": len(seeds), "wall_s": round(time.monotonic() - t0, 1),
           "rmse_m": ev.overall.rmse_m, "mean_m": ev.overall.mean_m, "max_m": ev.overall.max_m,
           "distance_m": ev.overall.distance_m,
           "mean_pct_distance": ev.overall.mean_pct_distance}
    ends, ends_z, maxes, rmses, tag_errs, step_pct = [], [], [], [], [], []
    for run in ev.runs:
        sim = simulate(row.scenario, run.seed) if row.measure == "tags" else None
        for agent, err in run.errors.items():
            maxes.append(float(err.horizontal.max()))
            rmses.append(float(np.sqrt(np.mean(err.horizontal ** 2))))
            ends.append(float(err.horizontal[-1]))
            ends_z.append(float(abs(err.vertical[-1])) if err.vertical.size else math.nan)
            tr, truth = run.tracks[agent], run.truth[agent]
            if row.measure == "tags":
                e, _ = checkpoint_errors(tr, _tag_checkpoints(sim, agent))
                tag_errs.extend(e.horizontal.tolist())
            if row.measure == "steps":
                pos = np.column_stack([np.interp(tr.t, truth.t, truth.position[:, i])
                                       for i in range(3)])
                e, _ = checkpoint_errors(tr, Checkpoints(agent, tr.t, pos, tr.floor),
                                         align="first:5", distance_m=err.distance_m)
                step_pct.append(100.0 * float(e.horizontal.mean()) / err.distance_m)
    out.update({"rmse_per_run_mean": float(np.mean(rmses)),
                "max_per_run_mean": float(np.mean(maxes)),
                "end_mean_m": float(np.mean(ends)), "end_min_m": float(np.min(ends)),
                "end_max_m": float(np.max(ends)), "end_vertical_mean_m": float(np.nanmean(ends_z))})
    if tag_errs:
        out.update({"tag_mean_m": float(np.mean(tag_errs)), "tag_std_m": float(np.std(tag_errs))})
    if step_pct:
        out.update({"step_pct_mean": float(np.mean(step_pct)),
                    "step_pct_min": float(np.min(step_pct)),
                    "step_pct_max": float(np.max(step_pct))})
    return out


def ours(row: Row, m: dict) -> str:
    if row.measure == "checkpoints":
        return f"RMSE {m['rmse_per_run_mean']:.2f}, max {m['max_per_run_mean']:.2f}"
    if row.measure == "tags":
        return f"mean {m.get('tag_mean_m', math.nan):.1f}, std {m.get('tag_std_m', math.nan):.1f}"
    if row.measure == "end":
        return (f"end {m['end_mean_m']:.1f} ({m['end_min_m']:.1f}-{m['end_max_m']:.1f}), "
                f"z {m['end_vertical_mean_m']:.1f}")
    if row.measure == "steps":
        return (f"{m['step_pct_mean']:.2f} % ({m['step_pct_min']:.2f}-"
                f"{m['step_pct_max']:.2f})")
    return f"RMSE {m['rmse_m']:.2f}, {m['mean_pct_distance']:.1f} % of {m['distance_m']:.0f} m"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scenarios", nargs="*", help="subset of scenarios (default all)")
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--json", type=Path, help="write the figures to this file")
    args = ap.parse_args()
    rows = [r for r in ROWS if not args.scenarios or r.scenario in args.scenarios]
    seeds = list(range(args.seeds))
    results = []
    print(f"INS alone (zupt_ins + dead_reckoning, ideal start alignment), seeds 0-{seeds[-1]}, "
          "metres unless stated")
    print(f"{'scenario':<18} {'IMU grade':<23} {'paper':<42} {'ours, as cal.':<30} "
          f"ours, +still")
    with tempfile.TemporaryDirectory() as tmp:
        for row in rows:
            a = measure(row, seeds, Path(tmp), still=False)
            b = measure(row, seeds, Path(tmp), still=True)
            results += [a, b]
            print(f"{row.scenario:<18} {a['grade']:<23} {row.paper:<42} {ours(row, a):<30} "
                  f"{ours(row, b)}  [{a['wall_s'] + b['wall_s']:.0f} s]", flush=True)
    if args.json:
        args.json.write_text(json.dumps(results, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
