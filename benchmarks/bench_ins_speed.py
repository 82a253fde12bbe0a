"""Throughput of the whole ZUPT-aided INS (detector + filter) on the real data, one core.

    .venv/bin/python benchmarks/bench_ins_speed.py [--reference-samples 12000]

Runs in one process, side by side on the same recordings:

* ours — the numba engine (``InsEngine``), adaptive detector (default), the previous
  round's defaults (``bench_ins_gaits.PREVIOUS``), fixed SHOE; default and previous on
  the four crawl trials alone (the averaged crawl statistic costs only there);
* ours through the plugin — ImuBlocks of 0.1 s into ``ZuptInsEstimator``, messages out;
* the reference — the plain numpy/Python implementation kept in
  ``tests/ins/reference_ins.py`` (same algorithm), on a subset (it is slow), and the
  largest difference between its output and ours on that subset.

Figures are IMU samples per second of CPU time of this process (``time.process_time``,
so other load on the machine does not count against us) and of wall time. Numba runs
single-threaded (NUMBA_NUM_THREADS=1; the kernels are sequential anyway).
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import numpy as np  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "benchmarks"))

from firenav_framework import ImuBlock  # noqa: E402
from firenav_framework.sources.readers.foot_imu_datasets import (  # noqa: E402
    load_indoor_walk, load_vicon_trial)
from firenav_framework.testing import make_component  # noqa: E402
from firenav_plugins.estimators.zupt_ins import (  # noqa: E402
    BlockResult, InsEngine, ZuptInsEstimator, ZuptInsParams)
from firenav_plugins.estimators.zupt_ins import eskf  # noqa: E402
from tests.ins import reference_ins  # noqa: E402

FLU = np.array([1.0, -1.0, -1.0])
RATE = 200.0
#: The VICON crawl trials are the session of this day (``vicon_motion``: all four).
CRAWL_SESSION = "2018-02-22"


def recordings() -> list[tuple[str, np.ndarray, np.ndarray, np.ndarray]]:
    root = Path(os.environ.get("FIRENAV_SHARED_DATA", REPO.parent / "shared" / "data"))
    if not root.is_dir():
        sys.exit(f"datasets not found at {root} (set FIRENAV_SHARED_DATA)")
    out = []
    for p in sorted((root / "pyshoe-vicon").glob("*.mat")):
        tr = load_vicon_trial(p)
        out.append((p.stem, tr.ts, np.ascontiguousarray(tr.accel * FLU),
                    np.ascontiguousarray(tr.gyro * FLU)))
    for p in sorted((root / "indoor-walks").glob("*.mat")):
        w = load_indoor_walk(p)
        out.append((p.stem, w.ts, np.ascontiguousarray(w.accel * FLU),
                    np.ascontiguousarray(w.gyro * FLU)))
    return out


def timed(fn) -> tuple[float, float]:
    c0, w0 = time.process_time(), time.perf_counter()
    fn()
    return time.process_time() - c0, time.perf_counter() - w0


def engine_run(params: ZuptInsParams, t, acc, gyro) -> BlockResult:
    eng = InsEngine(params.detector_config(RATE), params.filter_config(RATE))
    return BlockResult.concat([eng.process(t, acc, gyro), eng.finish()])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reference-samples", type=int, default=12000,
                    help="samples run through the slow reference (spread over 3 recordings)")
    args = ap.parse_args()
    recs = recordings()
    n_total = sum(len(r[1]) for r in recs)
    print(f"{len(recs)} recordings, {n_total} samples ({n_total / RATE / 60:.1f} min at 200 Hz)\n")

    rows = []
    from bench_ins_gaits import PREVIOUS
    crawls = [r for r in recs if r[0].startswith(CRAWL_SESSION)]
    for name, params, runs in (
            ("ours, adaptive detector (default)", ZuptInsParams(), recs),
            ("ours, previous round's defaults", PREVIOUS, recs),
            ("ours, fixed SHOE", ZuptInsParams(detector={"kind": "shoe"}), recs),
            ("ours, default, the 4 crawls only", ZuptInsParams(), crawls),
            ("ours, previous defaults, the 4 crawls only", PREVIOUS, crawls)):
        engine_run(params, *recs[0][1:])                       # compile / load the cache
        cpu, wall = timed(lambda: [engine_run(params, *r[1:]) for r in runs])
        rows.append((name, sum(len(r[1]) for r in runs), cpu, wall))

    def through_plugin() -> None:
        comp, _, _ = make_component(ZuptInsEstimator, {})
        for name, t, acc, gyro in recs:
            for i in range(0, len(t), 20):
                comp.handle("imu", ImuBlock.from_arrays(t[i:i + 20], acc[i:i + 20],
                                                        gyro[i:i + 20], agent=name,
                                                        device=f"{name}/imu"))
        comp.finish()
    cpu, wall = timed(through_plugin)
    rows.append(("ours via the zupt_ins plugin (0.1 s ImuBlocks)", n_total, cpu, wall))

    # the reference on a subset; the same subset through ours for the equality check
    per = args.reference_samples // 3
    subset = [(n, t[:per], a[:per], g[:per]) for n, t, a, g in (recs[0], recs[30], recs[-1])]
    params = ZuptInsParams()
    dc, fc = params.detector_config(RATE), params.filter_config(RATE)
    ref_out = []
    cpu, wall = timed(lambda: ref_out.extend(reference_ins.run(t, a, g, dc, fc)
                                             for _, t, a, g in subset))
    rows.append(("reference (numpy/Python, tests/ins/reference_ins.py)",
                 sum(len(s[1]) for s in subset), cpu, wall))
    diff_state = diff_event = 0.0
    zv_equal = True
    for (_, t, a, g), (states, events, _) in zip(subset, ref_out):
        ours = engine_run(params, t, a, g)
        zv_equal &= bool(np.array_equal(ours.states[:, eskf.O_ZV], states[:, eskf.O_ZV]))
        diff_state = max(diff_state, float(np.abs(ours.states - states).max()))
        if len(ours.events) == len(events):
            diff_event = max(diff_event, float(np.abs(ours.events - events).max()))
        else:
            diff_event = float("inf")

    print(f"{'implementation':52s} {'samples':>8s} {'CPU s':>7s} {'samples/s (CPU)':>16s} "
          f"{'samples/s (wall)':>17s}")
    for name, n, cpu, wall in rows:
        print(f"{name:52s} {n:8d} {cpu:7.2f} {n / cpu:16,.0f} {n / wall:17,.0f}")
    ours_rate = rows[0][1] / rows[0][2]
    ref_rate = rows[-1][1] / rows[-1][2]
    print(f"\nspeed-up of ours (default) over the reference: {ours_rate / ref_rate:,.0f}x; an hour "
          f"of a 100 Hz IMU takes {360000 / ours_rate:.2f} s of one core")
    print(f"ours vs reference on the subset: zero-velocity flags identical: {zv_equal}; largest "
          f"difference of states {diff_state:.1e}, of step events {diff_event:.1e}")


if __name__ == "__main__":
    main()
