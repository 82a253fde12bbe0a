"""Speed of the GEN/RMG estimator on a large team graph, against batch solvers.

The graph: 20 firefighters enter a 70 m x 50 m floor through doors along its outer walls
(surveyed from the base station) and walk 95 steps each (1 900 states), dropping a
breadcrumb whenever none is within 6 m (about 70 breadcrumbs, ~2 000 nodes in all).
Every state has a relative-position edge from the previous one (INS odometry),
breadcrumbs a drop edge to the dropping state; every state ranges to the 12 nearest
breadcrumbs (and the base station) within 15 m and to the other firefighters' current
states within 15 m; closer than 1.5 m a contact is an encounter (zero relative
position). About 19 000 edges, with loop closures wherever a firefighter passes a
breadcrumb anyone dropped earlier.

One *update* is one new firefighter state with all its edges (plus a drop when it
happens). Reported per update, in the same run:

* ours - :class:`GeneralizedElectricalNetwork` (incremental exact BLUE): add the node
  and edges, re-linearise stale ranges, return estimates and covariance blocks of every
  changed node (the new state and the nodes it measured);
* sparse batch BLUE - assemble the whole Kirchhoff matrix (eqs. 4, 7, 9, 20, 21),
  factorise it and get the same estimates and covariance blocks (every Nth update);
* GTSAM iSAM2 (update + estimate of the new state) and GTSAM batch
  Levenberg-Marquardt on the final graph, when ``gtsam`` is installed (the benchmark
  extra, ``pip install -e '.[bench]'``; never a dependency of firenav), with
  ``--heading-states`` on the same graph with the same heading nodes and edges.

With ``--heading-states`` every state also gets the heading state the ``breadcrumb_gen``
plugin uses (``h = (psi, omega, kappa)``, a linear motion edge from the previous one) and
its odometry is measured in a frame turned by a drifting heading error (a residual gyro
bias per firefighter) and enters as a rotated relative position: two nodes and one more
non-linear edge per update, timed against the sparse batch BLUE of the same graph.

At the end: the incremental estimates against the batch optimum of the same non-linear
problem (ours, and GTSAM's LM), and on the graph without ranges (linear) the incremental
estimates against the batch BLUE. BLAS runs single-threaded (small dense updates).

Before/after in one run: ``--compare DIR [DIR ...]`` times only ours (with and without
heading states) in other checkouts (e.g. ``git archive`` of older commits) and in this one,
alternating, each in a fresh process, wall and CPU time (``time.thread_time``) per
update: the CPU column is what the update costs on its own thread, the wall column adds
what the machine's other jobs took from it and any wait for the refactorisation worker.

Refactorisations run on a worker thread and are handed over ``--rebuild-lag`` (20)
updates after they start (0: on the update's own thread), where the checkout's GEN has
that option. The updates are fed back to back, or with ``--pace 1`` at their data rate
(20 firefighters, a step each per second), as a live pipeline gets them. A hand-over
waits for a late worker (deterministic; counted "waited for"), or with
``--handover-wait S`` at most S seconds, then goes on with the old factor (counted
"late").

The GEN runs with its class's own options (active-set bound 900 dimensions, 150 hot nodes,
background systems from 300 dimensions), or with ``--plugin-settings`` as the
``breadcrumb_gen`` plugin sets them (600, 50, 3000), the same in every checkout compared.

Run: ``.venv/bin/python benchmarks/bench_breadcrumb_graph.py [--seed 0] [--quick]
[--heading-states] [--compare DIR ...] [--pace X] [--rebuild-lag N] [--handover-wait S]
[--plugin-settings]``
"""
from __future__ import annotations

import argparse
import gc
import inspect
import json
import os
import subprocess
import sys
import time
from dataclasses import dataclass, field

# Small dense updates: one BLAS thread each is faster, and much faster on a loaded machine.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from firenav_plugins.estimators.breadcrumb_gen.measurements import rotate_z  # noqa: E402
from firenav_plugins.estimators.breadcrumb_gen.network import (  # noqa: E402
    GeneralizedElectricalNetwork, batch_blue)

#: Closer than this a radio contact is an encounter (§V-A): a zero relative position
#: with ENCOUNTER_SIGMA per axis instead of a range (whose direction is meaningless there).
ENCOUNTER_M = 1.5
ENCOUNTER_SIGMA = 0.75
#: Heading states (``--heading-states``): priors and random walks of a still-start
#: calibrated INS (the plugin's defaults before the uncalibrated-IMU ones), and the true
#: heading error's drift rate per firefighter [rad/s] (one step = 1 s).
HEADING_PRIOR = np.diag([0.035, 0.009, 0.02]) ** 2
HEADING_WALK = np.diag([1e-4, 1e-4, 1e-3]) ** 2
DRIFT_RATE_SIGMA = 0.005
#: Updates from the start of a refactorisation on the worker thread to its hand-over.
REBUILD_LAG = 20


@dataclass
class Update:
    """One new firefighter state and its edges."""

    key: str
    parent: str
    odo: np.ndarray                       # x_new - x_parent, measured
    odo_cov: np.ndarray
    ranges: list[tuple[str, float, float]] = field(default_factory=list)  # (other, r, var)
    encounters: list[str] = field(default_factory=list)   # nodes passed within 1.5 m
    drop: str | None = None               # breadcrumb dropped at this state
    psi: float = 0.0                      # true heading error of the odometry [rad]
    t: float = 0.0                        # data time of the state [s] (one step per second)


def make_graph(seed: int = 0, agents: int = 20, steps: int = 95, bc_spacing: float = 6.0,
               bc_range: float = 15.0, ff_range: float = 15.0, max_bc_ranges: int = 12,
               area: tuple[float, float] = (70.0, 50.0)
               ) -> tuple[list[Update], dict[str, np.ndarray]]:
    """The team graph of the module doc as a list of updates, plus the true positions."""
    rng = np.random.default_rng(seed)
    AREA = np.asarray(area, float)
    truth: dict[str, np.ndarray] = {"base": np.zeros(3)}
    # the teams enter through doors spread along the outer walls, surveyed from the base
    doors = rng.uniform(0, 2 * AREA.sum(), agents)
    pos = np.zeros((agents, 3))
    heading = np.zeros(agents)
    for a, u in enumerate(doors):
        if u < AREA[0]:
            pos[a, :2], heading[a] = (u, 0.5), np.pi / 2
        elif u < AREA.sum():
            pos[a, :2], heading[a] = (AREA[0] - 0.5, u - AREA[0]), np.pi
        elif u < AREA.sum() + AREA[0]:
            pos[a, :2], heading[a] = (u - AREA.sum(), AREA[1] - 0.5), -np.pi / 2
        else:
            pos[a, :2], heading[a] = (0.5, u - AREA.sum() - AREA[0]), 0.0
    drift = np.random.default_rng(seed + 1).normal(0, DRIFT_RATE_SIGMA, agents)  # [rad/s]
    last = [f"ff{a}@start" for a in range(agents)]
    crumbs: list[str] = []
    updates: list[Update] = []
    for a in range(agents):
        truth[last[a]] = pos[a].copy()
        updates.append(Update(last[a], "base", pos[a] + rng.normal(0, 0.3, 3), 0.09 * np.eye(3)))
    sig_odo = 0.05
    for s in range(steps):
        for a in range(agents):
            heading[a] += rng.normal(0, 0.35)
            step = 0.7 * np.array([np.cos(heading[a]), np.sin(heading[a]), 0.0])
            new = pos[a] + step
            for k in range(2):                   # bounce off the outer walls
                if not 0.0 <= new[k] <= AREA[k]:
                    step[k] = -step[k]
                    heading[a] = np.arctan2(step[1], step[0])
            pos[a] = pos[a] + step
            key = f"ff{a}@{s}"
            truth[key] = pos[a].copy()
            up = Update(key, last[a], step + rng.normal(0, sig_odo, 3), sig_odo ** 2 * np.eye(3),
                        psi=float(drift[a] * (s + 1)), t=float(s + 1))
            last[a] = key
            statics = ["base", *crumbs]
            sp_ = np.array([truth[c] for c in statics])
            dist = np.linalg.norm(sp_ - pos[a], axis=1)
            near = np.argsort(dist)[:max_bc_ranges]
            for k in near:
                if dist[k] < ENCOUNTER_M:
                    up.encounters.append(statics[k])
                elif dist[k] < bc_range:
                    up.ranges.append(_range(rng, statics[k], dist[k]))
            if dist.min() > bc_spacing:
                bc = f"bc{len(crumbs)}"
                crumbs.append(bc)
                truth[bc] = pos[a].copy()
                up.drop = bc
            for b in range(a):                   # the others' states of this step
                other = f"ff{b}@{s}"
                dd = float(np.linalg.norm(truth[other] - pos[a]))
                if dd < ENCOUNTER_M:
                    up.encounters.append(other)
                elif dd < ff_range:
                    up.ranges.append(_range(rng, other, dd))
            updates.append(up)
    return updates, truth


ENC_COV = ENCOUNTER_SIGMA ** 2 * np.eye(3)


def _range(rng: np.random.Generator, other: str, dist: float) -> tuple[str, float, float]:
    sigma = 0.1 + 0.15 * dist
    return other, max(0.05, dist + rng.normal(0, sigma)), sigma ** 2


def add_odometry(gen: GeneralizedElectricalNetwork, up: Update, heading_states: bool
                 ) -> list[str]:
    """The update's new state and its odometry edge; with heading states also its heading
    node (motion edge from the parent's, or the prior at the start) and the odometry as
    measured in the frame turned by ``-psi``. Returns the new nodes."""
    gen.add_node(up.key)
    if not heading_states:
        gen.add_relative_position(up.key, up.parent, up.odo, up.odo_cov)
        return [up.key]
    h = f"{up.key}/h"
    gen.add_node(h)
    if up.parent == "base":
        gen.add_linear([h], np.eye(3), HEADING_PRIOR, np.zeros(3))
        gen.add_relative_position(up.key, up.parent, up.odo, up.odo_cov)
    else:
        F = np.array([[1.0, 1.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])   # dt = 1 s
        gen.add_linear([h, f"{up.parent}/h"], np.hstack([np.eye(3), -F]), HEADING_WALK,
                       np.zeros(3))
        odo = rotate_z(up.odo[None], np.array([-up.psi]))[0]
        gen.add_rotated_position(up.key, up.parent, h, odo, up.odo_cov)
    return [up.key, h]


def add_encounters_and_drop(gen: GeneralizedElectricalNetwork, up: Update) -> None:
    """The update's encounters (zero relative positions) and its breadcrumb drop, if any."""
    for other in up.encounters:
        gen.add_relative_position(up.key, other, np.zeros(3), ENC_COV)
    if up.drop:
        gen.add_node(up.drop)
        gen.add_relative_position(up.drop, up.key, np.zeros(3), 0.09 * np.eye(3))


def plugin_settings() -> dict:
    """The GEN's options as the ``breadcrumb_gen`` plugin sets them by default (active-set
    bound, hot nodes, background size, re-linearisation threshold), without the lag and
    wait the benchmark sets itself."""
    from firenav_plugins.estimators.breadcrumb_gen.params import Graph
    options = Graph().network_options()
    return {k: v for k, v in options.items() if k not in ("rebuild_lag", "handover_wait")}


def new_network(rebuild_lag: int, handover_wait: float | None = None,
                settings: dict | None = None) -> GeneralizedElectricalNetwork:
    """The GEN with its own defaults, or ``settings`` (:func:`plugin_settings`), and
    refactorisations handed over ``rebuild_lag`` updates after they start (on a worker
    thread), waiting at most ``handover_wait`` [s] for a late one (None: until done),
    where the checkout's GEN has these options."""
    options = inspect.signature(GeneralizedElectricalNetwork).parameters
    kw = {**(settings or {}), "rebuild_lag": rebuild_lag, "handover_wait": handover_wait}
    return GeneralizedElectricalNetwork(3, **{k: v for k, v in kw.items() if k in options})


def run_ours(updates: list[Update], linear_only: bool = False, heading_states: bool = False,
             cpu: np.ndarray | None = None, pace: float = 0.0, rebuild_lag: int = REBUILD_LAG,
             handover_wait: float | None = None, settings: dict | None = None
             ) -> tuple[GeneralizedElectricalNetwork, np.ndarray]:
    """Our incremental GEN, one timed update per firefighter step (``linear_only``: the
    ranges left out, so that the batch BLUE is exact without iterations); wall seconds
    per update, and the CPU seconds into ``cpu`` when given. ``pace`` > 0 feeds the
    updates at ``pace`` times their data rate (1: live, 20 firefighters a step each per
    second) instead of back to back; ``settings``: see :func:`new_network`."""
    gen = new_network(rebuild_lag, handover_wait, settings)
    gen.add_anchor("base", np.zeros(3))
    lat = np.zeros(len(updates))
    gc.freeze()       # as firenav's runner does: the input built up front is not garbage
    try:
        return gen, _timed_updates(gen, updates, lat, linear_only, heading_states, cpu, pace)
    finally:
        gc.unfreeze()


def _timed_updates(gen: GeneralizedElectricalNetwork, updates: list[Update], lat: np.ndarray,
                   linear_only: bool, heading_states: bool, cpu: np.ndarray | None,
                   pace: float) -> np.ndarray:
    """Feed ``updates`` to ``gen``, wall seconds of each into ``lat`` (returned), CPU
    seconds into ``cpu`` when given (see :func:`run_ours`)."""
    start = time.perf_counter()
    for k, up in enumerate(updates):
        if pace > 0:
            time.sleep(max(0.0, start + up.t / pace - time.perf_counter()))
        t0 = time.perf_counter()
        c0 = time.thread_time()
        new = add_odometry(gen, up, heading_states)
        with gen.batch():
            if up.ranges and not linear_only:
                others, r, var = zip(*up.ranges)
                gen.add_ranges([up.key] * len(r), others, r, var)
            add_encounters_and_drop(gen, up)
        gen.relinearize()
        changed = [*new, *changed_nodes(up)[1:]]
        if up.drop:
            changed.append(up.drop)
        gen.estimates_of(changed)
        gen.covariances_of(changed)
        lat[k] = time.perf_counter() - t0
        if cpu is not None:
            cpu[k] = time.thread_time() - c0
    return lat


def changed_nodes(up: Update) -> list[str]:
    """The new state and every non-anchor node it measured."""
    return list(dict.fromkeys([up.key, *(o for o, _, _ in up.ranges if o != "base"),
                               *(o for o in up.encounters if o != "base")]))


def time_batch(gen: GeneralizedElectricalNetwork, changed: list[str]) -> float:
    t0 = time.perf_counter()
    system = gen.assemble()
    batch_blue(system, [gen.id_of(c) for c in changed])
    return time.perf_counter() - t0


def run_batch_sampled(updates: list[Update], every: int, heading_states: bool = False
                      ) -> np.ndarray:
    """Plain sparse batch BLUE after every ``every``-th update (same graph growth; only
    the batch solve is timed)."""
    gen = GeneralizedElectricalNetwork(3)
    gen.add_anchor("base", np.zeros(3))
    out = []
    for k, up in enumerate(updates):
        new = add_odometry(gen, up, heading_states)
        for other, r, var in up.ranges:
            gen.add_range(up.key, other, r, var)
        add_encounters_and_drop(gen, up)
        if k % every == every - 1:
            out.append(time_batch(gen, [*new, *changed_nodes(up)[1:]]))
    return np.array(out)


def _heading_factors(gtsam):
    """GTSAM factors of the heading states, as GTSAM's Python ``CustomFactor``s (it has no
    built-in for them): the motion edge ``h - F h_parent`` and the odometry measured in a
    frame turned by ``psi_h``, ``x_i - x_j - R_z(psi_h) zeta`` (the plugin's edges)."""
    F = np.array([[1.0, 1.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])

    def motion(h: int, parent: int):
        def error(this, values, jacobians):
            if jacobians is not None:
                jacobians[0] = np.eye(3)
                jacobians[1] = -F
            return values.atVector(h) - F @ values.atVector(parent)
        return gtsam.CustomFactor(gtsam.noiseModel.Gaussian.Covariance(HEADING_WALK),
                                  [h, parent], error)

    def rotated(i: int, j: int, h: int, zeta: np.ndarray, cov: np.ndarray):
        def error(this, values, jacobians):
            psi = values.atVector(h)[0]
            c, s_ = np.cos(psi), np.sin(psi)
            turned = np.array([c * zeta[0] - s_ * zeta[1], s_ * zeta[0] + c * zeta[1], zeta[2]])
            if jacobians is not None:
                jacobians[0] = np.eye(3)
                jacobians[1] = -np.eye(3)
                g = np.zeros((3, 3))
                g[:, 0] = -np.array([-s_ * zeta[0] - c * zeta[1], c * zeta[0] - s_ * zeta[1], 0.0])
                jacobians[2] = g
            return values.atPoint3(i) - values.atPoint3(j) - turned
        return gtsam.CustomFactor(gtsam.noiseModel.Gaussian.Covariance(cov), [i, j, h], error)

    return motion, rotated


def run_gtsam(updates: list[Update], gtsam, heading_states: bool = False) -> dict:
    """iSAM2 per update, then batch LM on the whole graph; with ``heading_states`` the
    same heading nodes and edges as :func:`add_odometry` gives ours."""
    motion, rotated = _heading_factors(gtsam)
    keys: dict[str, int] = {}

    def key(name: str) -> int:
        return keys.setdefault(name, len(keys))

    isam = gtsam.ISAM2(gtsam.ISAM2Params())
    full = gtsam.NonlinearFactorGraph()
    init_all = gtsam.Values()
    est: dict[str, np.ndarray] = {"base": np.zeros(3)}
    lat = np.zeros(len(updates))
    for k, up in enumerate(updates):
        graph = gtsam.NonlinearFactorGraph()
        vals = gtsam.Values()
        if k == 0:
            graph.add(gtsam.PriorFactorPoint3(key("base"), np.zeros(3),
                                              gtsam.noiseModel.Isotropic.Sigma(3, 1e-6)))
            vals.insert(key("base"), np.zeros(3))
        guess = est[up.parent] + up.odo
        vals.insert(key(up.key), guess)
        if heading_states and up.parent != "base":
            h = key(f"{up.key}/h")
            vals.insert(h, est[f"{up.parent}/h"])
            graph.add(motion(h, key(f"{up.parent}/h")))
            odo = rotate_z(up.odo[None], np.array([-up.psi]))[0]
            graph.add(rotated(key(up.key), key(up.parent), h, odo, up.odo_cov))
        else:
            if heading_states:
                h = key(f"{up.key}/h")
                vals.insert(h, np.zeros(3))
                graph.add(gtsam.PriorFactorVector(h, np.zeros(3),
                                                  gtsam.noiseModel.Gaussian.Covariance(HEADING_PRIOR)))
            # GTSAM's Between(a, b) measures x_b - x_a; our zeta_ij measures x_i - x_j
            graph.add(gtsam.BetweenFactorPoint3(key(up.parent), key(up.key), up.odo,
                                                gtsam.noiseModel.Gaussian.Covariance(up.odo_cov)))
        for other, r, var in up.ranges:
            graph.add(gtsam.RangeFactor3(key(up.key), key(other), r,
                                         gtsam.noiseModel.Isotropic.Sigma(1, np.sqrt(var))))
        for other in up.encounters:
            graph.add(gtsam.BetweenFactorPoint3(key(up.key), key(other), np.zeros(3),
                                                gtsam.noiseModel.Isotropic.Sigma(3, ENCOUNTER_SIGMA)))
        if up.drop:
            vals.insert(key(up.drop), guess)
            graph.add(gtsam.BetweenFactorPoint3(key(up.drop), key(up.key), np.zeros(3),
                                                gtsam.noiseModel.Isotropic.Sigma(3, 0.3)))
        t0 = time.perf_counter()
        isam.update(graph, vals)
        est[up.key] = isam.calculateEstimatePoint3(key(up.key))
        if heading_states:
            est[f"{up.key}/h"] = isam.calculateEstimateVector(key(f"{up.key}/h"))
        lat[k] = time.perf_counter() - t0
        if up.drop:
            est[up.drop] = isam.calculateEstimatePoint3(key(up.drop))
        full.push_back(graph)
        init_all.insert(vals)
    final = isam.calculateEstimate()
    t0 = time.perf_counter()
    params = gtsam.LevenbergMarquardtParams()
    params.setRelativeErrorTol(1e-14)
    params.setAbsoluteErrorTol(1e-14)
    params.setMaxIterations(500)
    lm = gtsam.LevenbergMarquardtOptimizer(full, init_all, params).optimize()
    batch_s = time.perf_counter() - t0
    names = {v: k for k, v in keys.items()}
    points = [k for k in final.keys() if not names[k].endswith("/h")]
    return {"lat": lat, "batch_s": batch_s,
            "isam": {names[k]: final.atPoint3(k) for k in points},
            "lm": {names[k]: lm.atPoint3(k) for k in points}}


def stats(lat_s: np.ndarray) -> str:
    ms = 1e3 * np.asarray(lat_s)
    return (f"median {np.median(ms):7.2f} ms  mean {ms.mean():7.2f} ms  "
            f"p95 {np.percentile(ms, 95):7.2f} ms  max {ms.max():7.1f} ms")


def with_cpu(fn, *args, **kw):
    """``fn(*args, **kw)`` and the CPU seconds of this process it took."""
    c0 = time.process_time()
    out = fn(*args, **kw)
    return out, time.process_time() - c0


def max_diff(a: dict, b: dict) -> float:
    common = [k for k in a if k in b and k != "base"]
    return float(max(np.max(np.abs(np.asarray(a[k]) - np.asarray(b[k]))) for k in common))


def time_ours(seed: int, steps: int, heading_states: bool, pace: float = 0.0,
              rebuild_lag: int = REBUILD_LAG, handover_wait: float | None = None,
              settings: dict | None = None) -> dict:
    """Wall and CPU per update [ms] of ours on the graph of ``seed`` (for ``--compare``)."""
    updates, _ = make_graph(seed, steps=steps)
    cpu = np.zeros(len(updates))
    gen, lat = run_ours(updates, heading_states=heading_states, cpu=cpu, pace=pace,
                        rebuild_lag=rebuild_lag, handover_wait=handover_wait,
                        settings=settings)
    if hasattr(gen, "finish_rebuild"):
        gen.finish_rebuild()    # no worker thread left running into the interpreter's exit
    return {"wall": (1e3 * lat).tolist(), "cpu": (1e3 * cpu).tolist(),
            "rebuilds": gen.solver.rebuilds,
            "background": getattr(gen, "background_rebuilds", 0),
            "waited": getattr(gen, "waited_handovers", 0),
            "late": getattr(gen, "late_handovers", 0)}


def ours_in_checkout(path: str, seed: int, steps: int, heading_states: bool,
                     pace: float = 0.0, rebuild_lag: int = REBUILD_LAG,
                     handover_wait: float | None = None, settings: dict | None = None) -> dict:
    """:func:`time_ours` run by the GEN of the checkout at ``path``, in a fresh process
    (``settings`` the same in every checkout)."""
    here = os.path.dirname(os.path.abspath(__file__))
    code = ("import json, sys; sys.path.insert(0, %r); import bench_breadcrumb_scaling as s; "
            "s.use_checkout(%r); import bench_breadcrumb_graph as g; "
            "print(json.dumps(g.time_ours(%d, %d, %r, %r, %d, %r, %r)))"
            % (here, path, seed, steps, heading_states, pace, rebuild_lag, handover_wait,
               settings))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, cwd=path)
    return json.loads(out.stdout.strip().splitlines()[-1])


def compare(others: list[str], seed: int, steps: int, pace: float, rebuild_lag: int,
            handover_wait: float | None = None, settings: dict | None = None) -> None:
    """Ours in the checkouts ``others`` and here, alternating, wall and CPU per update."""
    here = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    feed = f"paced at {pace:g}x the data rate" if pace > 0 else "back to back"
    wait = "until done" if handover_wait is None else f"at most {1e3 * handover_wait:g} ms"
    print(f"updates {feed}; this checkout hands refactorisations over {rebuild_lag} "
          f"updates after they start, waiting {wait} for a late one; GEN options: "
          f"{settings or 'its defaults'}")
    for heading in (False, True):
        for path in (*others, here):
            name = "this" if path == here else os.path.basename(os.path.normpath(path))
            r = ours_in_checkout(path, seed, steps, heading, pace, rebuild_lag, handover_wait,
                                 settings)
            print(f"{name:10s} {'heading states' if heading else 'positions only':14s} "
                  f"wall: {stats(np.array(r['wall']) / 1e3)} | CPU: "
                  f"{stats(np.array(r['cpu']) / 1e3)} [{r['rebuilds']} refactorisations, "
                  f"{r['background']} on the worker, hand-overs waited for "
                  f"{r.get('waited', 0)}, late {r.get('late', 0)}]", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--quick", action="store_true", help="smaller graph (smoke test)")
    ap.add_argument("--batch-every", type=int, default=50,
                    help="time the sparse batch BLUE after every Nth update")
    ap.add_argument("--heading-states", action="store_true",
                    help="also time the graph with the plugin's heading states")
    ap.add_argument("--compare", nargs="+", default=[], metavar="DIR", help="only ours, in "
                    "these checkouts and here (before/after in one run)")
    ap.add_argument("--pace", type=float, default=0.0, help="feed the updates at this "
                    "multiple of their data rate (1 = live) instead of back to back")
    ap.add_argument("--rebuild-lag", type=int, default=REBUILD_LAG, help="updates from the "
                    "start of a refactorisation on the worker thread to its hand-over "
                    "(0: refactorise on the update's own thread)")
    ap.add_argument("--handover-wait", type=float, default=None, metavar="S", help="wait "
                    "at most this long [s] for a refactorisation due at its hand-over "
                    "(default: until done, deterministic)")
    ap.add_argument("--plugin-settings", action="store_true", help="the GEN with the "
                    "breadcrumb_gen plugin's default options (active-set bound, hot nodes, "
                    "background size) instead of the class's own, in every checkout")
    args = ap.parse_args()
    settings = plugin_settings() if args.plugin_settings else None
    steps = 20 if args.quick else 95
    if args.compare:
        compare(args.compare, args.seed, steps, args.pace, args.rebuild_lag,
                args.handover_wait, settings)
        return
    updates, truth = make_graph(args.seed, steps=steps)
    n_nodes = 1 + len(updates) + sum(u.drop is not None for u in updates)
    n_edges = sum(1 + len(u.ranges) + len(u.encounters) + (u.drop is not None)
                  for u in updates)
    print(f"graph: {n_nodes} nodes, {n_edges} edges "
          f"({sum(len(u.ranges) for u in updates)} ranges, "
          f"{sum(len(u.encounters) for u in updates)} encounters), 20 agents, seed {args.seed}")

    (gen, lat), cpu = with_cpu(run_ours, updates, pace=args.pace, rebuild_lag=args.rebuild_lag,
                               handover_wait=args.handover_wait, settings=settings)
    print(f"ours (incremental GEN)     {stats(lat)}   "
          f"[{gen.solver.rebuilds} refactorisations, {gen.relinearised} relinearisations; "
          f"CPU {cpu:.1f} s, wall {lat.sum():.1f} s]")
    batch = run_batch_sampled(updates, args.batch_every)
    print(f"sparse batch BLUE          {stats(batch)}   (every {args.batch_every}th update)")
    inc = gen.estimates()
    t0 = time.perf_counter()
    iters = gen.optimize()
    opt_s = time.perf_counter() - t0
    opt = gen.estimates()
    print(f"our batch solution (Gauss-Newton/LM, all ranges re-linearised): "
          f"{1e3 * opt_s:.0f} ms, {iters} iterations")
    print(f"incremental (ranges linearised once, re-linearised when stale) vs batch "
          f"optimum: max |dx| = {max_diff(inc, opt):.3f} m")
    err = np.array([np.linalg.norm(opt[k][:2] - truth[k][:2]) for k in opt if k != "base"])
    print(f"accuracy vs truth (batch optimum): mean {err.mean():.2f} m, max {err.max():.2f} m")
    lin, lat_lin = run_ours(updates, linear_only=True)
    system = lin.assemble()
    x, _ = batch_blue(system)
    ref = {lin.key_of(n): x[k] for k, n in enumerate(system.nodes)}
    print(f"linear edges only: incremental {stats(lat_lin)}; "
          f"vs batch BLUE max |dx| = {max_diff(lin.estimates(), ref):.1e} m")

    if args.heading_states:
        (hs, lat_h), cpu_h = with_cpu(run_ours, updates, heading_states=True, pace=args.pace,
                                      rebuild_lag=args.rebuild_lag,
                                      handover_wait=args.handover_wait, settings=settings)
        print(f"with heading states: ours {stats(lat_h)}   [{hs.solver.rebuilds} "
              f"refactorisations, {hs.relinearised} relinearisations; CPU {cpu_h:.1f} s, "
              f"wall {lat_h.sum():.1f} s]")
        print(f"with heading states: sparse batch BLUE "
              f"{stats(run_batch_sampled(updates, args.batch_every, heading_states=True))}")
        inc_h = {k: v for k, v in hs.estimates().items() if not str(k).endswith("/h")}
        hs.optimize()
        opt_h = {k: v for k, v in hs.estimates().items() if not str(k).endswith("/h")}
        print(f"with heading states: incremental vs batch optimum max |dx| = "
              f"{max_diff(inc_h, opt_h):.3f} m")
    try:
        import gtsam
    except ImportError:
        print("GTSAM: not installed (pip install gtsam) - iSAM2 / LM columns skipped")
        return
    g, cpu_g = with_cpu(run_gtsam, updates, gtsam)
    print(f"GTSAM iSAM2 (update+est.)  {stats(g['lat'])}   [CPU {cpu_g:.1f} s incl. batch "
          f"LM, wall {g['lat'].sum():.1f} s of updates]")
    if args.heading_states:
        gh, cpu_gh = with_cpu(run_gtsam, updates, gtsam, heading_states=True)
        print(f"with heading states: GTSAM iSAM2 (update+est.) {stats(gh['lat'])}   "
              f"[CPU {cpu_gh:.1f} s incl. batch LM, wall {gh['lat'].sum():.1f} s of updates] "
              f"(its heading edges are Python CustomFactors); batch LM "
              f"{1e3 * gh['batch_s']:.0f} ms; ours batch optimum vs GTSAM LM max |dx| = "
              f"{max_diff(opt_h, gh['lm']):.1e} m")
    print(f"GTSAM batch LM on the final graph: {1e3 * g['batch_s']:.0f} ms")
    print(f"final estimates: ours (batch optimum) vs GTSAM LM max |dx| = "
          f"{max_diff(opt, g['lm']):.1e} m; ours incremental vs iSAM2 final "
          f"{max_diff(inc, g['isam']):.3f} m; iSAM2 vs GTSAM LM {max_diff(g['isam'], g['lm']):.3f} m")


if __name__ == "__main__":
    main()
