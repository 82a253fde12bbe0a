"""Floor right with and without a worn barometer, no stair map, pdr_ekf.

    .venv/bin/python benchmarks/bench_rfid_baro.py --seeds 1000-1019
    .venv/bin/python benchmarks/bench_rfid_baro.py --scenario field_multifloor_long --seeds 100-119

No bundled scenario carries a barometer and the simulator has no barometer model, so the
heights a worn barometer would report are made from the simulator's truth by
tests/rfid/baro_sim.py (zeroing error, indoor offset drifting over minutes, stairwell
pressure, weather residue, noise). Per seed: the simulator and a foot INS with its
defaults (no still start); pdr_ekf without tags and without the stair map (the paper's
counted stairs), once with the barometer's heights and once without, on the same
strides. Floor right as ``firenav evaluate`` counts it (on the stairs either
neighbouring floor). Default scenario: tests/rfid/data/rfid_consumer_baro.yaml (the RFID
route up two floors and back, consumer IMU).
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from benchmarks.bench_rfid_ekf import parse_seeds  # noqa: E402
from firenav_framework.evaluation.metrics import floor_right  # noqa: E402
from firenav_framework.testing import make_component  # noqa: E402
from firenav_plugins.estimators.pdr_ekf import PdrEkfEstimator  # noqa: E402
from tests.rfid.baro_sim import baro_heights, simulated_strides  # noqa: E402
from tests.rfid.synth import feed  # noqa: E402

SCENARIO = REPO / "tests" / "rfid" / "data" / "rfid_consumer_baro.yaml"
NO_MAP = {"rfid": {"enabled": False}, "height": {"stair_zone": None}}


def floors_right(poses, truth, building) -> np.ndarray:
    """1/0 per pose of one agent: the floor right (either one on the stairs)."""
    t = np.array([p.t for p in poses])
    est = np.array([p.floor for p in poses])
    z = np.interp(t, truth.t, truth.position[:, 2])
    true_floor = np.array([building.floor_of_z(v) for v in z])
    levels = np.array([f.z for f in building.floors])
    return floor_right(est, true_floor, z, levels)


def run_seed(scenario, seed: int) -> dict[str, np.ndarray]:
    odo, truth, building = simulated_strides(scenario, seed)
    rng = np.random.default_rng(seed)
    baro = [h for agent in truth for h in baro_heights(truth[agent], agent, rng)]
    out = {}
    for name, extra in (("without", []), ("with", baro)):
        ekf, rec, _ = make_component(PdrEkfEstimator, NO_MAP, building=building)
        ekf.start()
        feed(ekf, odo + extra)
        out[name] = np.concatenate([
            floors_right([p for p in rec.on("pose") if p.agent == a], truth[a], building)
            for a in truth])
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default=str(SCENARIO))
    ap.add_argument("--seeds", default="1000-1019")
    ap.add_argument("--json", type=Path)
    args = ap.parse_args(argv)
    seeds = parse_seeds(args.seeds)
    per = {"without": [], "with": []}
    for seed in seeds:
        r = run_seed(args.scenario, seed)
        for k in per:
            per[k].append(r[k])
        print(f"seed {seed}: floor right without {r['without'].mean():.3f}, with "
              f"{r['with'].mean():.3f}", file=sys.stderr, flush=True)
    rows = {}
    for k, runs in per.items():
        fr = np.array([np.nanmean(r) for r in runs])
        rows[k] = {"pooled": float(np.nanmean(np.concatenate(runs))), "min": float(fr.min()),
                   "median": float(np.median(fr)), "max": float(fr.max())}
    print(f"\n{Path(args.scenario).stem}, seeds {seeds[0]}-{seeds[-1]} ({len(seeds)} runs), "
          "pdr_ekf without stair map or tags")
    print("| barometer | floor right pooled | per run min / median / max |\n|---|---|---|")
    for k, r in rows.items():
        print(f"| {k} | {100 * r['pooled']:.2f} % | {100 * r['min']:.1f} / "
              f"{100 * r['median']:.1f} / {100 * r['max']:.1f} % |")
    if args.json:
        args.json.write_text(json.dumps({"seeds": [seeds[0], seeds[-1]], "rows": rows}, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
