"""Refactorisations on a worker thread (issue 21): the estimate while one is pending, after
its hand-over, and independence from the worker's timing."""
from __future__ import annotations

import math
import threading
import time

import numpy as np

from firenav_plugins.estimators.breadcrumb_gen import incremental
from firenav_plugins.estimators.breadcrumb_gen.network import (
    GeneralizedElectricalNetwork, batch_blue)

from tests.breadcrumb.dense_blue import DenseGraph
from tests.breadcrumb.test_network import TOL, assert_matches_dense, build_random, heading_chain


def test_linear_graph_equals_dense_blue_while_pending_and_after_hand_over():
    """Every refactorisation goes to the worker (no size threshold) and is handed over two
    updates later: eqs. 4-5 still hold to 1e-9 after every update, pending or not (on a
    linear graph the previous factor's estimate is exact too)."""
    pending = 0
    for gen, dense in build_random(1, 40, 24, rebuild_lag=2, background_dims=0):
        gen.relinearize()                       # one call per update: the hand-over clock
        pending += gen.rebuild_pending
        assert_matches_dense(gen, dense)
    assert gen.background_rebuilds > 5 and pending > 5
    assert gen.solver.rebuilds + gen.rebuild_pending >= gen.background_rebuilds


def test_sliding_window_with_heading_states_through_background_rebuilds():
    """Marginalised nodes (hidden while a rebuild is pending, replayed at the hand-over)
    and heading states keep the BLUE of the full graph."""
    gen = GeneralizedElectricalNetwork(3, relinearize_sigma=math.inf, max_active_dims=30,
                                       hot_nodes=3, rebuild_lag=3, background_dims=0)
    for gen, dense, live in heading_chain(gen, DenseGraph(3), np.random.default_rng(12), 60,
                                          window=4):
        gen.relinearize()
    assert gen.background_rebuilds > 3
    gen.finish_rebuild()
    est, sigma, col = dense.solve()
    for key in live:
        np.testing.assert_allclose(gen.estimate(key), est[key], atol=TOL)
        i = col[key] * 3
        np.testing.assert_allclose(gen.covariance(key), sigma[i:i + 3, i:i + 3], atol=TOL)


def ranged_walk(gen: GeneralizedElectricalNetwork, steps: int, seed: int = 5):
    """A walker in a 12 m square with ranges to four breadcrumbs (non-linear edges that get
    re-linearised); yields after each update, with the re-linearisation check done."""
    rng = np.random.default_rng(seed)
    gen.add_anchor("base", np.zeros(3))
    crumbs = {f"bc{k}": np.array([x, y, 0.0]) for k, (x, y) in
              enumerate([(10, 0), (10, 10), (0, 10), (5, 5)])}
    for name, p in crumbs.items():
        gen.add_node(name)
        gen.add_relative_position(name, "base", p + rng.normal(size=3) * 0.5, 0.25 * np.eye(3))
    truth = np.zeros(3)
    prev = "base"
    for k in range(steps):
        step = 0.8 * np.array([math.cos(k / 6), math.sin(k / 6), 0.0])
        truth = truth + step
        key = f"x{k}"
        gen.add_node(key)
        gen.add_relative_position(key, prev, step + rng.normal(size=3) * 0.1, 0.02 * np.eye(3))
        with gen.batch():
            for name, p in crumbs.items():
                r = float(np.linalg.norm(truth - p))
                if r < 9:
                    gen.add_range(key, name, r + rng.normal() * 0.2, 0.04)
        gen.relinearize(0.01)
        prev = key
        yield gen


def test_estimate_after_a_hand_over_is_the_batch_solution():
    """Right after each hand-over the estimates are the batch BLUE of the system as now
    linearised (the replayed operations included), to 1e-8 m."""
    gen = GeneralizedElectricalNetwork(3, max_active_dims=60, hot_nodes=5, rebuild_lag=3,
                                       background_dims=0)
    handed = 0
    was_pending = False
    for gen in ranged_walk(gen, 70):
        if was_pending and not gen.rebuild_pending:
            handed += 1
            system = gen.assemble()
            x, _ = batch_blue(system)
            ours = gen.estimates()
            for k, nid in enumerate(system.nodes):
                np.testing.assert_allclose(ours[gen.key_of(nid)], x[k], atol=1e-8, rtol=0)
        was_pending = gen.rebuild_pending
    assert handed >= 3 and gen.relinearised > 0


def _track(lag: int) -> tuple[dict, int]:
    gen = GeneralizedElectricalNetwork(3, max_active_dims=60, hot_nodes=5, rebuild_lag=lag,
                                       background_dims=0)
    out = {}
    for k, gen in enumerate(ranged_walk(gen, 60)):
        out[k] = gen.estimates_of([f"x{k}"])[0].copy()
    return out, gen.background_rebuilds


def test_replay_is_identical_whatever_the_worker_timing(monkeypatch):
    """A worker that finishes late (here: every time, 30 ms after it was started), or that
    catches up slowly on the logged operations (5 ms each), changes when the caller waits
    at a hand-over, never what it publishes: identical tracks, bit for bit."""
    prompt, n = _track(2)
    run = incremental._Worker.run

    def late(self):
        time.sleep(0.03)
        run(self)

    monkeypatch.setattr(incremental._Worker, "run", late)
    delayed, n_delayed = _track(2)
    monkeypatch.setattr(incremental._Worker, "run", run)
    main = threading.current_thread()
    update = incremental.IncrementalBlue.update

    def slow(self, *args):
        if threading.current_thread() is not main:
            time.sleep(0.005)
        update(self, *args)

    monkeypatch.setattr(incremental.IncrementalBlue, "update", slow)
    behind, n_behind = _track(2)
    assert n == n_delayed == n_behind > 3
    for k in prompt:
        assert np.array_equal(prompt[k], delayed[k]), k
        assert np.array_equal(prompt[k], behind[k]), k


def _serving_system(gen: GeneralizedElectricalNetwork):
    """The Kirchhoff system the serving factor solves while a rebuild is pending: the
    tables, with the edges the snapshot re-linearised at the points the serving factor
    still holds for them."""
    b, rng, rot = gen._behind, gen._rng, gen._rot
    saved = rng.li[b.rng].copy(), rng.lj[b.rng].copy(), rot.lin[b.rot].copy()
    rng.li[b.rng], rng.lj[b.rng], rot.lin[b.rot] = b.li, b.lj, b.lin
    try:
        return gen.assemble()
    finally:
        rng.li[b.rng], rng.lj[b.rng], rot.lin[b.rot] = saved


def test_stale_edges_are_relinearised_while_pending():
    """While a rebuild is pending the stale ranges are re-linearised in the system of the
    next factor (the Gauss-Newton steps go on there), and the published estimates stay the
    batch BLUE of the system the serving factor holds, to 1e-8 m, after every update."""
    gen = GeneralizedElectricalNetwork(3, max_active_dims=60, hot_nodes=5, rebuild_lag=4,
                                       background_dims=0)
    relinearised_pending = checked = 0
    was_pending, count = False, 0
    for gen in ranged_walk(gen, 70):
        if was_pending and gen.rebuild_pending:     # no rebuild started in between
            relinearised_pending += gen.relinearised - count
        if gen.rebuild_pending:
            system = _serving_system(gen)
            x, _ = batch_blue(system)
            ours = gen.estimates()
            for i, nid in enumerate(system.nodes):
                np.testing.assert_allclose(ours[gen.key_of(nid)], x[i], atol=1e-8, rtol=0)
            checked += 1
        was_pending, count = gen.rebuild_pending, gen.relinearised
    assert checked > 10 and relinearised_pending > 10
    assert gen.background_rebuilds > 3


def test_bounded_hand_over_moves_a_late_factor_to_a_later_update(monkeypatch):
    """With ``handover_wait`` a worker that is not done when its hand-over is due does not
    hold the update: the serving factor goes on (counted late), and once the worker is
    done the next update hands it over; the estimates are then the batch BLUE of the
    system as now linearised. Without it the update waits (counted) and nothing is late."""
    release = threading.Event()
    run = incremental._Worker.run

    def held(self):
        release.wait()
        run(self)

    monkeypatch.setattr(incremental._Worker, "run", held)
    gen = GeneralizedElectricalNetwork(3, max_active_dims=60, hot_nodes=5, rebuild_lag=2,
                                       background_dims=0, handover_wait=0.0)
    walk = ranged_walk(gen, 70)
    while not gen.rebuild_pending:
        next(walk)
    for _ in range(6):                      # due after 2 updates, the worker still held
        next(walk)
    assert gen.rebuild_pending and gen.late_handovers >= 4
    release.set()
    gen.solver.rebuild_ready(60.0)
    next(walk)
    assert gen.waited_handovers == 0
    if gen.rebuild_pending:                # handed over, and a new one started at once
        gen.finish_rebuild()
    system = gen.assemble()
    x, _ = batch_blue(system)
    ours = gen.estimates()
    for i, nid in enumerate(system.nodes):
        np.testing.assert_allclose(ours[gen.key_of(nid)], x[i], atol=1e-8, rtol=0)


def test_hand_over_applies_no_logged_operation_on_the_callers_thread(monkeypatch):
    """The worker catches up on the operations logged while it was pending (it applies
    them to its own solver as they come): the hand-over only swaps that solver in, so no
    operation is replayed on the pipeline's thread (they were, 8-25 ms per hand-over)."""
    calls = {"hand-over": 0, "caught up": 0, "on the caller": 0}
    main = threading.current_thread()
    finish = incremental.IncrementalBlue.finish_rebuild
    in_hand_over = threading.local()

    def watched(self):
        in_hand_over.on = True
        calls["hand-over"] += 1
        try:
            return finish(self)
        finally:
            in_hand_over.on = False

    def counting(name):
        op = getattr(incremental.IncrementalBlue, name)

        def wrapper(self, *args, **kw):
            if threading.current_thread() is main and getattr(in_hand_over, "on", False):
                calls["on the caller"] += 1
            return op(self, *args, **kw)
        return wrapper

    monkeypatch.setattr(incremental.IncrementalBlue, "finish_rebuild", watched)
    for name in ("update", "border", "hide"):
        monkeypatch.setattr(incremental.IncrementalBlue, name, counting(name))
    gen = GeneralizedElectricalNetwork(3, max_active_dims=60, hot_nodes=5, rebuild_lag=3,
                                       background_dims=0)
    for gen in ranged_walk(gen, 70):
        if gen.rebuild_pending:
            calls["caught up"] += gen.solver.rebuild_ready(60.0)   # the worker keeps up
    assert calls["hand-over"] >= 3 and calls["caught up"] > 10
    assert calls["on the caller"] == 0


def test_the_worker_goes_on_only_between_updates():
    """The worker's sparse solves and Python steps hold the GIL, so it applies an update's
    operations only once the update is done (its ``relinearize()`` call), not while the
    update is still adding edges: here one update's edges wait 50 ms for that call and the
    worker applies none of them meanwhile; after the call it catches up on all."""
    gen = GeneralizedElectricalNetwork(3, max_active_dims=60, hot_nodes=5, rebuild_lag=50,
                                       background_dims=0)
    walk = ranged_walk(gen, 70)
    while not gen.rebuild_pending:
        next(walk)
    next(walk)                                  # the first update with the worker released
    worker = gen.solver._worker
    assert gen.solver.rebuild_ready(60.0)
    done = worker._applied
    gen.add_node("x-extra")
    gen.add_relative_position("x-extra", "bc3", np.zeros(3), 0.5 * np.eye(3))
    gen.add_range("x-extra", "bc0", 7.0, 0.04)
    time.sleep(0.05)
    assert len(worker._ops) > done and worker._applied == done
    gen.relinearize()
    assert gen.solver.rebuild_ready(60.0) and worker._applied == len(worker._ops)


def test_the_dense_set_is_never_reallocated_on_the_callers_thread():
    """With refactorisations in the background the serving solver's dense covariance is
    allocated up front for the largest set a pending refactorisation lets it reach: it is
    replaced only at a hand-over (by the worker's, allocated on the worker), never grown
    by an update (growing it copies the whole matrix, tens of ms at a few thousand
    dimensions)."""
    gen = GeneralizedElectricalNetwork(3, max_active_dims=60, hot_nodes=5, rebuild_lag=4,
                                       background_dims=0)
    solver = gen.solver
    before = (solver._sig, solver.rebuilds)
    grown = handed_over = 0
    peak = 0
    for gen in ranged_walk(gen, 80):
        peak = max(peak, solver.active_dims)
        if solver.rebuilds != before[1]:
            handed_over += 1
        elif solver._sig is not before[0]:
            grown += 1
        before = (solver._sig, solver.rebuilds)
    assert handed_over >= 3 and peak > 48      # past the smallest allocation
    assert grown == 0


def test_a_background_refactorisation_starts_before_the_bound():
    """With a lag the refactorisation is due at ``background_start`` of the active set's
    bound, so that the set, which grows on while it is pending, stays near the bound:
    each start comes as the set passes that fraction, and the
    largest set reached is smaller than when starting at the bound itself."""
    def run(start: float) -> tuple[list[int], int]:
        gen = GeneralizedElectricalNetwork(3, max_active_dims=90, hot_nodes=5,
                                           rebuild_lag=4, background_dims=0,
                                           background_start=start)
        rng = np.random.default_rng(3)
        gen.add_anchor("base", np.zeros(3))
        prev, at_start, peak, started = "base", [], 0, 0
        for k in range(120):                    # a linear chain with fixes to the base
            key = f"x{k}"
            gen.add_node(key)
            gen.add_relative_position(key, prev, rng.normal(size=3), 0.02 * np.eye(3))
            if k % 7 == 6:
                gen.add_relative_position(key, "base", rng.normal(size=3), np.eye(3))
            gen.relinearize()
            prev = key
            peak = max(peak, gen.solver.active_dims)
            if gen.background_rebuilds != started:
                started = gen.background_rebuilds
                at_start.append(gen.solver.active_dims)
        return at_start, peak

    early, early_peak = run(0.5)
    late, late_peak = run(1.0)
    assert len(early) >= 3 and len(late) >= 2
    # checked as an update begins: the set is then past the fraction by at most one
    # node, and the update adds its own
    assert all(45 < dims <= 45 + 2 * 3 for dims in early), early
    assert all(90 < dims <= 90 + 2 * 3 for dims in late), late
    assert early_peak < late_peak


def test_background_start_outside_its_range_is_refused():
    """A start fraction of zero or less, or above the bound, is a clear error, not a network
    that refactorises every update or never before the forced hand-over."""
    for bad in (0.0, -0.5, 1.5, math.nan):
        try:
            GeneralizedElectricalNetwork(3, rebuild_lag=2, background_start=bad)
        except ValueError as exc:
            assert "background_start" in str(exc)
        else:
            raise AssertionError(f"background_start={bad} accepted")


def test_refactorisation_keeps_every_walkers_chain_ends_active():
    """The hot nodes re-activated after a refactorisation are the chains' ends first: each
    walker's latest state and heading node (its next odometry edge extends both), even when
    ranges to older nodes were touched since (a team's round of updates). The heading enters
    its state's rotated odometry edge through a rank-1 gain, so it stays an end until its own
    next heading is bordered from it."""
    F = np.array([[1.0, 1.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    walk, prior = 1e-4 * np.eye(3), 1e-3 * np.eye(3)
    gen = GeneralizedElectricalNetwork(3, relinearize_sigma=math.inf,
                                       max_active_dims=10 ** 6, hot_nodes=4)
    gen.add_anchor("base", np.zeros(3))
    rng = np.random.default_rng(3)
    steps = 12
    for k in range(steps):
        for w, side in (("a", 1.0), ("b", -1.0)):
            key, h = f"{w}{k}", f"{w}{k}/h"
            gen.add_node(key)
            gen.add_node(h)
            step = np.array([1.0, side * 0.1, 0.0]) + rng.normal(0, 0.02, 3)
            if k == 0:
                gen.add_linear([h], np.eye(3), prior, np.zeros(3))
                gen.add_relative_position(key, "base", step, 0.01 * np.eye(3))
            else:
                gen.add_linear([h, f"{w}{k - 1}/h"], np.hstack([np.eye(3), -F]), walk,
                               np.zeros(3))
                gen.add_rotated_position(key, f"{w}{k - 1}", h, step, 0.01 * np.eye(3))
    for old in ("a3", "a4", "b5", "b6"):            # ranges to older states, touched last
        r = float(np.linalg.norm(gen.estimate(f"b{steps - 1}") - gen.estimate(old)))
        gen.add_range(f"b{steps - 1}", old, r, 0.01)
    gen.rebuild()
    ends = [f"a{steps - 1}", f"a{steps - 1}/h", f"b{steps - 1}", f"b{steps - 1}/h"]
    assert [gen.solver.is_active(gen.id_of(k)) for k in ends] == [True] * 4
    before = gen.solver.activated
    for w in ("a", "b"):                            # each walker's next step: no activation
        key, h, last = f"{w}{steps}", f"{w}{steps}/h", f"{w}{steps - 1}"
        gen.add_node(key)
        gen.add_node(h)
        gen.add_linear([h, f"{last}/h"], np.hstack([np.eye(3), -F]), walk, np.zeros(3))
        gen.add_rotated_position(key, last, h, np.array([1.0, 0.0, 0.0]), 0.01 * np.eye(3))
        gen.estimate(key)
    assert gen.solver.activated == before
