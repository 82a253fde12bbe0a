"""Speed-up of `firenav evaluate` on a Dask LocalCluster against the serial evaluation.

The same evaluation (default: the breadcrumb GEN pipeline, 8 tuning seeds 100-107) runs
serially in this process and on LocalClusters of 1, 2, ... single-threaded worker
processes (loopback). For each it prints the wall time, runs per minute, the speed-up
over serial, and checks that every run's figures equal the serial ones. Startup (the
cluster, then one short warm-up run on every worker: imports and numba's cached
machine code) is timed apart from the evaluation, and also shown end to end. All
clusters are started first and the configurations are timed in turn, ``--repeat``
times, keeping each one's fastest: a load that drifts while the script runs then
slows every configuration alike instead of the last ones.

The executor's own per-run overhead is measured twice: as the round trip of an empty
task on a 1-worker cluster, and as (1-worker evaluation - serial evaluation) / runs.

Speed figures depend on what else the machine does: the load average before and after
is printed; compare only figures from one run of this script.

    .venv/bin/python benchmarks/bench_evaluate_scaling.py [--pipeline breadcrumb|pf]
        [--seeds 8] [--workers 1,2,3] [--empty-tasks 200] [--repeat 1]
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from firenav_framework.evaluation.runs import evaluate, plan_evaluation, run_one  # noqa: E402
from firenav_framework.evaluation.seeds import SEED_SETS  # noqa: E402
from firenav_framework.scaleout import DaskExecutor, SerialExecutor, Task  # noqa: E402

PIPELINES = {
    "breadcrumb": (ROOT / "pipelines" / "breadcrumb-gen.yaml", "gen.pose"),
    "pf": (ROOT / "pipelines" / "search-pattern-pf.yaml", "pf.pose"),
}


def warm_up(pipeline: str, stream: str) -> float:
    """One short run (30 s of data): imports, plugin discovery, numba's cache. Seconds."""
    t0 = time.perf_counter()
    plan = plan_evaluation(pipeline, seeds=[0], stream=stream,
                           overrides=["sources.sim.duration=30"])
    run_one(plan.runs[0])
    return time.perf_counter() - t0


def empty() -> None:
    return None


def load() -> str:
    a, b, c = os.getloadavg()
    return f"{a:.2f} {b:.2f} {c:.2f} (1/5/15 min, {os.cpu_count()} cores)"


def figures(ev) -> list:
    return [(r.seed, r.figures) for r in ev.runs]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--pipeline", choices=sorted(PIPELINES), default="breadcrumb")
    ap.add_argument("--seeds", type=int, default=8, help="runs (tuning seeds from 100)")
    ap.add_argument("--workers", default="1,2,3", help="cluster sizes to measure")
    ap.add_argument("--empty-tasks", type=int, default=200,
                    help="empty tasks for the per-task round trip")
    ap.add_argument("--repeat", type=int, default=1, help="evaluate each configuration this "
                    "many times and keep the fastest (a shared machine's noise only slows)")
    args = ap.parse_args()
    pipeline, stream = PIPELINES[args.pipeline]
    seeds = list(SEED_SETS["tuning"])[:args.seeds]
    sizes = [int(w) for w in args.workers.split(",")]
    kw = dict(seeds=seeds, stream=stream)
    print(f"load before: {load()}")
    print(f"{pipeline.name}, {len(seeds)} runs (seeds {seeds[0]}-{seeds[-1]})\n")

    warm = warm_up(str(pipeline), stream)
    executors = {"serial": SerialExecutor()}
    startup = {"serial": (0.0, warm)}
    try:
        for n in sizes:       # all clusters up front; idle workers cost next to nothing
            t0 = time.perf_counter()
            ex = DaskExecutor(workers=n)
            t_start = time.perf_counter() - t0
            t0 = time.perf_counter()
            ex.client.run(warm_up, str(pipeline), stream)
            name = f"{n} worker{'s' if n > 1 else ''}"
            executors[name], startup[name] = ex, (t_start, time.perf_counter() - t0)
        best = {name: float("inf") for name in executors}
        evs = {}
        for _ in range(max(1, args.repeat)):      # interleaved: drifting load hits all alike
            for name, ex in executors.items():
                t0 = time.perf_counter()
                evs[name] = evaluate(pipeline, executor=ex, **kw)
                best[name] = min(best[name], time.perf_counter() - t0)
        one = executors.get("1 worker")
        overhead_task = None
        if one is not None:
            tasks = [Task(f"e{i}", f"empty {i}", empty) for i in range(args.empty_tasks)]
            t0 = time.perf_counter()
            for _ in one.run(tasks):
                pass
            overhead_task = (time.perf_counter() - t0) / args.empty_tasks
    finally:
        for ex in executors.values():
            ex.close()
    serial, t_serial = evs["serial"], best["serial"]
    t_one = best.get("1 worker")
    rows = [(name, *startup[name], best[name], figures(evs[name]) == figures(serial),
             sum(r.wall_s for r in evs[name].runs), sum(r.cpu_s for r in evs[name].runs))
            for name in executors]

    print(f"{'executor':<11} {'startup s':>9} {'warm-up s':>9} {'evaluate s':>10} "
          f"{'runs/min':>8} {'speed-up':>8} {'end to end':>10} {'runs own s':>10} "
          f"{'runs CPU s':>10}  same figures")
    for name, t_start, t_warm, t_eval, same, own, cpu in rows:
        e2e = t_serial / (t_start + t_warm + t_eval) if name != "serial" else 1.0
        print(f"{name:<11} {t_start:>9.1f} {t_warm:>9.1f} {t_eval:>10.1f} "
              f"{60 * len(seeds) / t_eval:>8.1f} {t_serial / t_eval:>7.2f}x {e2e:>9.2f}x "
              f"{own:>10.1f} {cpu:>10.1f}  "
              f"{'yes' if same else 'NO'}")
    print("\n(speed-up: serial evaluate / evaluate; end to end: serial evaluate / "
          "(startup + warm-up + evaluate); runs own s / CPU s: the runs' wall / CPU times "
          "summed, as measured inside each run, of the last repeat: own s above CPU s means "
          "the runs waited for a core)")
    if overhead_task is not None and t_one is not None:
        print(f"executor overhead per run: empty-task round trip {1000 * overhead_task:.1f} ms "
              f"({args.empty_tasks} tasks, 1 worker); 1-worker minus serial evaluate "
              f"{1000 * (t_one - t_serial) / len(seeds):.0f} ms per run "
              f"(runs of {t_serial / len(seeds):.2f} s)")
    print(f"load after: {load()}")


if __name__ == "__main__":
    main()
