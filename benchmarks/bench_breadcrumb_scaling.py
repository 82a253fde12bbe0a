"""Does breadcrumb_gen's cost per update stay bounded as the mission grows? (issue 21)

The ``breadcrumb_gen`` plugin itself (marginalisation window, heading states, the
defaults) on a synthetic mission: ``--agents`` firefighters walk laps of a 40 m x 10 m
ring from the base station, one step a second, starting 7 s apart, with a heading drift
(a residual gyro bias); eight breadcrumbs lie on the ring. Passing within 0.6 m of a
breadcrumb (or the base) gives an encounter, within 2.5 m a near RSSI range every 2 s.
The same mission is run for 2, 4 and 8 laps (``--laps``): a cost per update that is bounded
in the mission length gives the same median / p95 / max per update and a total time
linear in the laps (time per step flat).

One *update* is everything done while handling one odometry step (the new state and the
radio events it releases, marginalisation, re-linearisation, the published poses),
timed in wall and in CPU time (``time.thread_time``: what the update costs, without what
other jobs on the machine took from it). Each row also gives the seconds of data per
second of wall and of CPU time (x real time) and the process's peak resident memory;
``--agents 30 --laps 2`` is issue 21's 30-firefighter team.

Before/after in one run: ``--compare DIR`` also times the plugin from another checkout
(e.g. a ``git worktree`` of the commit before a change), alternating the two per mission
length so both see the same machine load.

Run: ``.venv/bin/python benchmarks/bench_breadcrumb_scaling.py [--agents 3] [--laps 2,4,8]
[--compare /tmp/old-checkout]``
"""
from __future__ import annotations

import argparse
import json
import math
import os
import resource
import subprocess
import sys
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from breadcrumb_walks import loop_path  # noqa: E402

BASE = np.array([0.0, 0.0, 1.0])
CRUMBS = {f"bc{k}": xy for k, xy in enumerate(
    [(10.0, 0.0), (20.0, 0.0), (30.0, 0.0), (40.0, 5.0), (30.0, 10.0), (20.0, 10.0),
     (10.0, 10.0), (0.0, 5.0)], start=1)}


def mission(agents: int, laps: int, seed: int = 0) -> list:
    """Time-ordered ``(stream, message)`` pairs of the whole team."""
    from firenav_framework import BreadcrumbDrop, Odometry, Range
    rng = np.random.default_rng(seed)
    events = []
    dropped: set[str] = set()
    path = loop_path(laps)[:, :2]
    for a in range(agents):
        ff = f"ff{a + 1}"
        t0 = 10.0 + 7.0 * a
        rate = rng.normal(0.0, 0.002)                       # heading drift [rad/s]
        pos = np.r_[path[0], 0.0]
        last_range: dict[str, float] = {}
        for k in range(1, len(path)):
            t = t0 + k
            d = path[k] - path[k - 1]
            psi = rate * k
            c, s = math.cos(psi), math.sin(psi)
            dm = np.array([c * d[0] - s * d[1], s * d[0] + c * d[1], 0.0]) \
                + rng.normal(0, 0.02, 3)
            pos = pos + dm
            events.append((t, "odo", Odometry(
                t=t, agent=ff, device=f"{ff}/ins", t_start=t - 1.0, delta=dm,
                dheading=0.0, cov=np.diag([4e-4] * 3 + [1e-4]), position=pos.copy(),
                heading=0.0)))
            for node, xy in [("base", BASE[:2]), *CRUMBS.items()]:
                dist = float(np.hypot(*(path[k] - xy)))
                if node != "base" and node not in dropped and dist < 0.6:
                    dropped.add(node)
                    events.append((t, "drops", BreadcrumbDrop(
                        t=t, agent=ff, device=f"{ff}/dispenser", node_id=node)))
                elif (node == "base" or node in dropped) and dist < 0.6:
                    events.append((t, "enc", Range(t=t, agent=ff, a=ff, b=node,
                                                   range_m=1.2, sigma_m=1.0,
                                                   method="rssi_encounter")))
                elif (node == "base" or node in dropped) and dist < 2.5 \
                        and t - last_range.get(node, -math.inf) >= 2.0:
                    last_range[node] = t
                    r = math.hypot(dist, 1.15) * math.exp(rng.normal(0, 0.2))
                    events.append((t, "rng", Range(t=t, agent=ff, a=ff, b=node, range_m=r,
                                                   sigma_m=0.3 * r, method="rssi")))
    events.sort(key=lambda e: e[0])
    return [(s, m) for _, s, m in events]


def time_updates(agents: int, laps: int) -> dict:
    """Per-update latencies [s] of the plugin on one mission."""
    from firenav_framework.testing import make_component
    from firenav_plugins.estimators.breadcrumb_gen import BreadcrumbGenEstimator
    msgs = mission(agents, laps)
    comp, _, _ = make_component(BreadcrumbGenEstimator, {"base": {"position": BASE.tolist()}})
    comp.start()
    lat, cpu, acc, acc_cpu = [], [], 0.0, 0.0
    wall0, cpu0 = time.perf_counter(), time.thread_time()
    for s, m in msgs:
        t0, c0 = time.perf_counter(), time.thread_time()
        comp.handle(s, m)
        acc += time.perf_counter() - t0
        acc_cpu += time.thread_time() - c0
        if s == "odo":
            lat.append(acc)
            cpu.append(acc_cpu)
            acc = acc_cpu = 0.0
    comp.finish()
    total, total_cpu = time.perf_counter() - wall0, time.thread_time() - cpu0
    span = msgs[-1][1].t - msgs[0][1].t
    lat, cpu = np.array(lat), np.array(cpu)
    return {"steps": len(lat), "median_ms": 1e3 * float(np.median(lat)),
            "p95_ms": 1e3 * float(np.percentile(lat, 95)), "max_ms": 1e3 * float(lat.max()),
            "cpu_median_ms": 1e3 * float(np.median(cpu)),
            "cpu_p95_ms": 1e3 * float(np.percentile(cpu, 95)),
            "cpu_max_ms": 1e3 * float(cpu.max()),
            "total_s": total, "per_step_ms": 1e3 * total / len(lat),
            "realtime_wall": span / total, "realtime_cpu": span / total_cpu,
            "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
            "nodes": comp.gen.node_count}


def use_checkout(path: str) -> None:
    """Import ``firenav_framework`` and ``firenav_plugins`` from the checkout at ``path``."""
    import importlib.util
    sys.path.insert(0, path)
    spec = importlib.util.spec_from_file_location(
        "firenav_plugins", os.path.join(path, "plugins", "__init__.py"),
        submodule_search_locations=[os.path.join(path, "plugins")])
    module = importlib.util.module_from_spec(spec)
    sys.modules["firenav_plugins"] = module
    spec.loader.exec_module(module)


def in_checkout(path: str, agents: int, laps: int) -> dict:
    """:func:`time_updates` run by the plugin of the checkout at ``path`` (a fresh
    process, so that each checkout is timed alone)."""
    code = ("import json, sys; sys.path.insert(0, %r); import bench_breadcrumb_scaling as b; "
            "b.use_checkout(%r); print(json.dumps(b.time_updates(%d, %d)))"
            % (os.path.dirname(os.path.abspath(__file__)), path, agents, laps))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, cwd=path)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--agents", type=int, default=3)
    ap.add_argument("--laps", default="2,4,8")
    ap.add_argument("--compare", default="", help="another checkout to time beside this one")
    args = ap.parse_args()
    here = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    rows = []
    for laps in [int(x) for x in args.laps.split(",")]:
        for name, path in ([("before", args.compare)] if args.compare else []) + [("this", here)]:
            r = in_checkout(path, args.agents, laps)
            rows.append((name, laps, r))
            print(f"{name:6s} {args.agents} ff x {laps} laps: {r['steps']:5d} updates, "
                  f"wall median {r['median_ms']:.2f} / p95 {r['p95_ms']:.2f} / max "
                  f"{r['max_ms']:.1f} ms, CPU median {r['cpu_median_ms']:.2f} / p95 "
                  f"{r['cpu_p95_ms']:.2f} / max {r['cpu_max_ms']:.1f} ms; total "
                  f"{r['total_s']:.2f} s = {r['per_step_ms']:.2f} ms per step; "
                  f"{r['realtime_wall']:.1f}x real time (wall), {r['realtime_cpu']:.1f}x (CPU); "
                  f"peak RSS {r['peak_rss_mb']:.0f} MB; {r['nodes']} live nodes", flush=True)


if __name__ == "__main__":
    main()
