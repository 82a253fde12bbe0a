"""Floor right with and without a worn barometer, consumer IMU, no stair map, pdr_ekf.

    .venv/bin/python benchmarks/bench_rfid_baro.py --seeds 1000-1019
    .venv/bin/python benchmarks/bench_rfid_baro.py --scenario field_apartments --seeds 100-107

The bundled multi-floor scenarios carry worn barometers and the reference at the
entrance (the simulator's MS5611-class model: weather, stack effect, door openings,
fire, device offset, drift, noise, quantisation, latency; docs/scenarios.md). Per seed
and scenario: the simulator with every foot IMU of the consumer grade, a foot INS with
its defaults (no still start) and the ``barometer`` sensor with its defaults (tests/rfid/
simulated.py); pdr_ekf without tags and without the stair map (the paper's counted
stairs), once with the barometer's heights and once without, on the same strides: the
pipelines/pdr-baro.yaml pipeline and its baseline (barometer off), run once per seed
instead of twice. Floor right as ``firenav evaluate`` counts it (on the stairs either
neighbouring floor), over every agent's poses; per run the min / median / max.
"""
from __future__ import annotations

import argparse
import json
import pickle
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from firenav_framework.evaluation.metrics import floor_right  # noqa: E402
from firenav_framework.evaluation.seeds import parse_seeds  # noqa: E402
from firenav_framework.testing import make_component  # noqa: E402
from firenav_plugins.estimators.pdr_ekf import PdrEkfEstimator  # noqa: E402
from tests.rfid.simulated import simulated_inputs  # noqa: E402
from tests.rfid.synth import feed  # noqa: E402

SCENARIOS = ("zupt_multifloor", "field_multifloor_long", "field_apartments", "incident")
NO_MAP = {"rfid": {"enabled": False}, "height": {"stair_zone": None}}


def floors_right(poses, truth, building) -> np.ndarray:
    """1/0 per pose of one agent: the floor right (either one on the stairs)."""
    t = np.array([p.t for p in poses])
    est = np.array([p.floor for p in poses])
    z = np.interp(t, truth.t, truth.position[:, 2])
    true_floor = np.array([building.floor_of_z(v) for v in z])
    levels = np.array([f.z for f in building.floors])
    return floor_right(est, true_floor, z, levels)


def inputs(scenario, seed: int, cache: Path | None):
    """The simulated strides and heights of one run (kept in ``cache`` when given, so
    that several pdr_ekf settings are tried on the same runs)."""
    path = cache / f"{Path(scenario).stem}_{seed}.pkl" if cache else None
    if path is not None and path.is_file():
        return pickle.loads(path.read_bytes())
    out = simulated_inputs(scenario, seed, imu_grade="consumer")
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(pickle.dumps(out))
    return out


def run_seed(scenario, seed: int, params: dict | None = None,
             cache: Path | None = None) -> dict[str, np.ndarray]:
    """Floor right (1/0 per pose, every agent with a barometer) without and with it."""
    odo, heights, truth, building = inputs(scenario, seed, cache)
    worn = sorted({h.agent for h in heights})
    out = {}
    for name, extra in (("without", []), ("with", heights)):
        ekf, rec, _ = make_component(PdrEkfEstimator, {**NO_MAP, **(params or {})},
                                     building=building)
        ekf.start()
        feed(ekf, [o for o in odo if o.agent in worn] + extra)
        out[name] = np.concatenate([
            floors_right([p for p in rec.on("pose") if p.agent == a], truth[a], building)
            for a in worn])
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", action="append", help="scenario (bundled name or file); "
                    f"repeat for several (default: {', '.join(SCENARIOS)})")
    ap.add_argument("--seeds", default="1000-1019")
    ap.add_argument("--set", dest="params", default="{}", help="pdr_ekf parameters as JSON "
                    "(e.g. '{\"barometer\": {\"gate\": 1.0}}')")
    ap.add_argument("--json", type=Path)
    ap.add_argument("--cache", type=Path, help="keep the simulated runs here (pickles of "
                    "this code version: delete them when the simulator or INS changes)")
    args = ap.parse_args(argv)
    seeds = parse_seeds(args.seeds)
    params = json.loads(args.params)
    table = {}
    for scenario in args.scenario or SCENARIOS:
        per = {"without": [], "with": []}
        for seed in seeds:
            r = run_seed(scenario, seed, params, args.cache)
            for k in per:
                per[k].append(r[k])
            print(f"{Path(scenario).stem} seed {seed}: floor right without "
                  f"{r['without'].mean():.4f}, with {r['with'].mean():.4f}", file=sys.stderr,
                  flush=True)
        rows = {}
        for k, runs in per.items():
            fr = np.array([np.nanmean(r) for r in runs])
            rows[k] = {"pooled": float(np.nanmean(np.concatenate(runs))), "min": float(fr.min()),
                       "median": float(np.median(fr)), "max": float(fr.max()),
                       "runs": [float(x) for x in fr]}
        table[Path(scenario).stem] = rows
        if args.json:    # after every scenario: a long run's finished rows are kept
            args.json.write_text(json.dumps({"seeds": [seeds[0], seeds[-1]], "params": params,
                                             "scenarios": table}, indent=1))
    print(f"\nseeds {seeds[0]}-{seeds[-1]} ({len(seeds)} runs), consumer IMU, pdr_ekf without "
          "stair map or tags" + (f", {params}" if params else ""))
    print("| scenario | barometer | floor right pooled | per run min / median / max |\n"
          "|---|---|---|---|")
    for name, rows in table.items():
        for k, r in rows.items():
            print(f"| {name} | {k} | {100 * r['pooled']:.2f} % | {100 * r['min']:.1f} / "
                  f"{100 * r['median']:.1f} / {100 * r['max']:.1f} % |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
