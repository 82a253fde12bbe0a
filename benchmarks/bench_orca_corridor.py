"""ORCA map matching on the corridor tests I-III of the ORCA paper (§3.2), beside INS alone.

Each test is the bundled simulator scenario ``orca_test1..3`` (the paper's corridor with
side rooms, the anchor at the start, check points where the walker stops), run for
``--seeds`` seeds through ``pipelines/orca-map-matching.yaml`` and, on the same seeds,
through ``pipelines/ins-baseline.yaml`` (the same INS, no map). Errors are measured at
the check points (the paper's eq. 10 RMSE), pooled over all seeds; the per-run RMSE
median, the largest check-point error and the number of runs worse than INS alone on
the same seed are shown too. The paper's Tables 2 and 3 are printed beside them (its
INS and IMU differ from the simulated ones: compare the gain, not the absolute
figures).

Rows: the bundled pipeline (anchor_range, wall_follow, orca) and ORCA alone (§2.2 with
this implementation's guards). ``--ablation`` adds each companion left out, ORCA's
paper rules without the guards (turn guard, door range gate, minimum step), without
the door-pass rule, and the ``rotation_from: heading`` variant.

Run: ``.venv/bin/python benchmarks/bench_orca_corridor.py [--seeds 10] [--first-seed 0]
[--ablation]`` (about 3 s per run on one free core).
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from firenav_framework.evaluation.runs import evaluate

ROOT = Path(__file__).resolve().parents[1]
ORCA = ROOT / "pipelines" / "orca-map-matching.yaml"
INS = ROOT / "pipelines" / "ins-baseline.yaml"
#: Paper, Table 2 (RMSE) and Table 3 (max error) [m]: (INS, map matching).
PAPER = {1: ((3.63, 3.01), (4.16, 3.71)), 2: ((3.26, 0.73), (3.89, 2.12)),
         3: ((5.59, 1.15), (7.06, 2.15))}
ORCA_ONLY = "estimators.mm.constraints=[{plugin: orca, input: uwb.range}]"
C = "estimators.mm.constraints.0"            # the orca constraint when it is alone
VARIANTS = {
    "ours: ranges + wall + ORCA": [],
    "ORCA alone (+ guards)": [ORCA_ONLY],
}
ABLATION = {
    "without wall_follow": ["estimators.mm.constraints=[{plugin: anchor_range, input: "
                            "uwb.range}, {plugin: orca, input: uwb.range}]"],
    "without anchor_range": ["estimators.mm.constraints=[{plugin: wall_follow}, "
                             "{plugin: orca, input: uwb.range}]"],
    "ORCA alone, paper rules only": [ORCA_ONLY, f"{C}.turn_guard=null",
                                     f"{C}.door_range_gate=1e9", f"{C}.min_step=0"],
    "ORCA alone, no door pass": [ORCA_ONLY, f"{C}.door_pass=false"],
    "ORCA alone, rotation from heading": [ORCA_ONLY, f"{C}.rotation_from=heading"],
}


def figures(ev, baseline=None) -> tuple:
    """Pooled RMSE, median per-run RMSE, largest error [m] at the check points, and how
    many runs are worse than ``baseline``'s run on the same seed."""
    per_run = [m.rmse_m for r in ev.runs for m in r.metrics.values()]
    worse = "" if baseline is None else sum(
        a > b for a, b in zip(per_run, [m.rmse_m for r in baseline.runs
                                        for m in r.metrics.values()]))
    return ev.overall.rmse_m, float(np.median(per_run)), ev.overall.max_m, worse


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--tests", default="1,2,3")
    ap.add_argument("--ablation", action="store_true")
    args = ap.parse_args()
    seeds = list(range(args.first_seed, args.first_seed + args.seeds))
    variants = {**VARIANTS, **ABLATION} if args.ablation else VARIANTS
    rows = []
    for test in (int(t) for t in args.tests.split(",")):
        scenario = f"orca_test{test}"
        ins_ev = evaluate(INS, scenario=scenario, seeds=seeds, truth_mode="checkpoints")
        rows.append((test, "INS alone (same INS, no map)", figures(ins_ev)))
        for name, over in variants.items():
            rows.append((test, name, figures(evaluate(ORCA, scenario=scenario, seeds=seeds,
                                                      overrides=over,
                                                      truth_mode="checkpoints"), ins_ev)))
        (p_ins, p_mm), (m_ins, m_mm) = PAPER[test]
        rows.append((test, "paper: INS / map matching",
                     (f"{p_ins} / {p_mm}", "", f"{m_ins} / {m_mm}", "")))
    print(f"check-point errors over seeds {seeds[0]}..{seeds[-1]} "
          "(simulated LSM6DS33 foot INS)")
    print(f"{'test':<6}{'pipeline':<36}{'RMSE [m]':>13}{'median run':>12}{'max [m]':>13}"
          f"{'worse runs':>12}")
    for test, name, (rmse, med, mx, worse) in rows:
        num = not isinstance(rmse, str)
        fmt = (lambda v: f"{v:13.2f}") if num else (lambda v: f"{v:>13}")
        med_s = f"{med:12.2f}" if num else f"{med:>12}"
        print(f"{'T' + 'I' * test:<6}{name:<36}{fmt(rmse)}{med_s}{fmt(mx)}{worse!s:>12}")


if __name__ == "__main__":
    main()
