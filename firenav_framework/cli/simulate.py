"""``firenav simulate SCENARIO --out DIR``: run a scenario and write its recordings.

The folder then holds what live sensors would have recorded (IMU CSV per foot IMU,
the other sensor streams as JSON lines) plus the ground truth; replay it with the
``recording`` source pointed at ``DIR/streams.jsonl``. ``--list`` shows the bundled
scenarios by family (paper, field, twin, demo). Formats: docs/formats/simulation-output.md.
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

from . import UsageError

#: How ``--list`` introduces each family of bundled scenarios (a scenario's ``family``).
FAMILIES = {
    "paper": "the reference papers' experiments, IMUs as worn (imu_errors: calibrated or "
             "datasheet for a unit calibrated at the door or on a lab bench)",
    "field": "field conditions: uncalibrated IMUs without a still start, furniture, plans "
             "that are wrong, deviating searches, large and multi-floor buildings, drawn "
             "radio, failing breadcrumbs, several teams",
    "twin": "twins of the real recordings in ../shared/data",
    "demo": "the embedded default",
}
FAMILY_ORDER = ["paper", "field", "twin", "demo"]


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("simulate", help="simulate a scenario and write its recordings and "
                       "ground truth")
    p.add_argument("scenario", nargs="?", help="scenario YAML file or bundled scenario name")
    p.add_argument("--out", type=Path, metavar="DIR", help="output folder (default: "
                   "out/sim/<scenario>-<seed>)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--duration", type=float, metavar="S", help="stop after S seconds")
    p.add_argument("--foot-truth", action="store_true", help="also write the foot's true "
                   "motion at every IMU sample (foot_<agent>.csv)")
    p.add_argument("--list", action="store_true", help="list the bundled scenarios and exit")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..simulator import bundled_scenarios, load_scenario, simulate
    from ..simulator.output import write_simulation
    if args.list:
        families: dict[str, list] = {}
        for name in bundled_scenarios():
            sc = load_scenario(name)
            families.setdefault(sc.model.family or "other", []).append(sc)
        for family in sorted(families, key=lambda f: (FAMILY_ORDER.index(f)
                                                      if f in FAMILY_ORDER else 99, f)):
            print(f"{family}: {FAMILIES.get(family, '')}")
            for sc in families[family]:
                print(f"  {sc.name:<26} {sc.model.description}")
        return 0
    if not args.scenario:
        raise UsageError("give a scenario (file or bundled name), or --list")
    if args.seed < 0:
        raise UsageError("--seed must be >= 0")
    if args.duration is not None and not args.duration > 0:
        raise UsageError("--duration must be positive")
    sc = load_scenario(args.scenario)
    t0 = time.monotonic()
    result = simulate(sc, args.seed, duration_s=args.duration)
    wall = time.monotonic() - t0
    out = args.out or Path("out") / "sim" / f"{sc.name}-{args.seed}"
    files = write_simulation(result, out, foot_truth=args.foot_truth)
    print(f"{sc.name} seed {args.seed}: {len(result.truth)} agents, {result.t_end:.1f} s "
          f"simulated in {wall:.2f} s")
    for agent, tr in result.truth.items():
        rec = result.imu.get(agent)
        imu = f", IMU {rec.grade} {rec.rate_hz:g} Hz" if rec else ""
        print(f"  {agent}: {tr.distance_m:.1f} m walked{imu}")
    counts = ", ".join(f"{p} {len(m)}" for p, m in result.messages.items() if p != "truth")
    if counts:
        print(f"  messages: {counts}")
    print(f"wrote {len(files)} files to {out}/ (replay: recording source, path "
          f"{out / 'streams.jsonl'})")
    return 0
