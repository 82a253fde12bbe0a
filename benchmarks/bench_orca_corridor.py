"""ORCA map matching on the corridor tests I-III of the ORCA paper (§3.2), beside INS alone.

Each test is the bundled simulator scenario ``orca_test1..3`` (the paper's corridor with
side rooms, the anchor at the start, check points where the walker stops), run for
``--seeds`` seeds through ``pipelines/orca-map-matching.yaml`` and, on the same seeds,
through ``pipelines/ins-baseline.yaml`` (the same INS, no map). Errors are measured at
the check points (the paper's eq. 10 RMSE), pooled over all seeds; the per-run RMSE
median and the largest check-point error are shown too. The paper's Tables 2 and 3 are
printed beside them (its INS and IMU differ from the simulated ones: compare the gain,
not the absolute figures).

``--ablation`` adds the paper's rules without this implementation's guards (turn guard,
door range gate, minimum step) and the ``rotation_from: heading`` variant.

Run: ``.venv/bin/python benchmarks/bench_orca_corridor.py [--seeds 10] [--ablation]``
(about 3 s per run on one core).
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
C = "estimators.mm.constraints.0"
VARIANTS = {
    "ORCA (ours, defaults)": [],
    "ORCA, paper rules only": [f"{C}.turn_guard=null", f"{C}.door_range_gate=1e9",
                               f"{C}.min_step=0"],
    "ORCA, rotation_from heading": [f"{C}.rotation_from=heading"],
}


def figures(ev) -> tuple[float, float, float]:
    """Pooled RMSE, median per-run RMSE and largest error [m] at the check points."""
    per_run = [m.rmse_m for r in ev.runs for m in r.metrics.values()]
    return ev.overall.rmse_m, float(np.median(per_run)), ev.overall.max_m


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--tests", default="1,2,3")
    ap.add_argument("--ablation", action="store_true")
    args = ap.parse_args()
    variants = VARIANTS if args.ablation else dict(list(VARIANTS.items())[:1])
    rows = []
    for test in (int(t) for t in args.tests.split(",")):
        scenario = f"orca_test{test}"
        ins = figures(evaluate(INS, scenario=scenario, seeds=args.seeds,
                               truth_mode="checkpoints"))
        rows.append((test, "INS alone (same INS, no map)", ins))
        for name, over in variants.items():
            rows.append((test, name, figures(evaluate(ORCA, scenario=scenario,
                                                      seeds=args.seeds, overrides=over,
                                                      truth_mode="checkpoints"))))
        (p_ins, p_mm), (m_ins, m_mm) = PAPER[test]
        rows.append((test, "paper: INS / map matching",
                     (f"{p_ins} / {p_mm}", "", f"{m_ins} / {m_mm}")))
    print(f"check-point errors over {args.seeds} seeds (simulated LSM6DS33 foot INS)")
    print(f"{'test':<6}{'pipeline':<32}{'RMSE [m]':>13}{'median run':>12}{'max [m]':>13}")
    for test, name, (rmse, med, mx) in rows:
        fmt = (lambda v: f"{v:13.2f}") if not isinstance(rmse, str) else (lambda v: f"{v:>13}")
        med_s = f"{med:12.2f}" if not isinstance(med, str) else f"{med:>12}"
        print(f"{'T' + 'I' * test:<6}{name:<32}{fmt(rmse)}{med_s}{fmt(mx)}")


if __name__ == "__main__":
    main()
