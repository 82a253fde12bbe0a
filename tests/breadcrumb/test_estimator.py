"""breadcrumb_gen on synthetic walks: encounters bound PDR drift, exact marginalisation
window (§IV-E), speed outliers (§IV-F), kicked breadcrumbs (§V-C), bad input."""
from __future__ import annotations

import math

import numpy as np
import pytest

from firenav_framework import BreadcrumbDrop, Odometry, Range
from firenav_framework.testing import check_plugin, make_component, run_component
from firenav_plugins.estimators.breadcrumb_gen import BreadcrumbGenEstimator

from benchmarks.breadcrumb_walks import loop_path

BASE = np.array([0.0, 0.0, 1.0])
CRUMBS = {"bc1": (20.0, 0.0), "bc2": (40.0, 5.0), "bc3": (20.0, 10.0), "bc4": (0.0, 5.0)}


def walk(laps: int = 3, drift_deg_per_lap: float = 10.0, seed: int = 0, kick: bool = False):
    """(messages, truth (N, 3) at the step times, step times) of one firefighter."""
    rng = np.random.default_rng(seed)
    truth = loop_path(laps)
    t = np.arange(len(truth), dtype=float) + 10.0
    psi = np.radians(drift_deg_per_lap) * np.arange(len(truth)) / 100.0
    msgs = []
    odo_pos = truth[0].copy()
    crumbs = dict(CRUMBS)
    dropped = set()
    for k in range(1, len(truth)):
        d = truth[k] - truth[k - 1]
        c, s = math.cos(psi[k]), math.sin(psi[k])
        dm = np.array([c * d[0] - s * d[1], s * d[0] + c * d[1], 0.0]) + rng.normal(0, 0.02, 3)
        odo_pos = odo_pos + dm
        msgs.append(("odo", Odometry(t=t[k], agent="ff1", device="ff1/ins", t_start=t[k - 1],
                                     delta=dm, dheading=0.0, cov=np.diag([4e-4] * 3 + [1e-4]),
                                     position=odo_pos.copy(), heading=0.0)))
        if kick and t[k] in (250.0, 300.0):      # kicked, then a false alarm: moved again
            crumbs["bc1"] = (21.5, 0.0)
            msgs.append(("moved", BreadcrumbDrop(t=t[k], node_id="bc1", device="kick_detector")))
        for bc, xy in crumbs.items():
            if np.hypot(*(truth[k, :2] - xy)) < 0.6:
                if bc not in dropped:
                    dropped.add(bc)
                    msgs.append(("drops", BreadcrumbDrop(t=t[k], agent="ff1",
                                                         device="ff1/dispenser", node_id=bc)))
                else:
                    msgs.append(("enc", Range(t=t[k], agent="ff1", a="ff1", b=bc, range_m=0.8,
                                              sigma_m=1.0, method="rssi_encounter")))
        if np.hypot(*(truth[k, :2] - BASE[:2])) < 0.6:
            msgs.append(("enc", Range(t=t[k], agent="ff1", a="ff1", b="base", range_m=1.2,
                                      sigma_m=1.0, method="rssi_encounter")))
    return msgs, truth[1:], t[1:]


# the walk's encounters happen within 0.6 m (no fading lets one through from further)
PARAMS = {"base": {"position": BASE.tolist()}, "odometry": {"noise_per_m": 0.05},
          "radio": {"near_sigma": 0.6}}
PAPER = {**PARAMS, "heading": {"enabled": False},                 # position-only GEN
         "odometry": {"noise_per_m": 0.3}}


def errors(rec, truth):
    poses = rec.on("pose")
    est = np.array([p.position for p in poses])
    return np.hypot(*(est[:, :2] - truth[:, :2]).T)


def pdr_errors(msgs, truth):
    odo = np.array([m.position for s, m in msgs if s == "odo"])
    return np.hypot(*(odo[:, :2] - truth[:, :2]).T)


def test_encounters_bound_the_drift_of_pdr():
    msgs, truth, _ = walk()
    rec = run_component(BreadcrumbGenEstimator, PARAMS, msgs)
    gen, pdr = errors(rec, truth), pdr_errors(msgs, truth)
    assert len(gen) == len(truth)
    assert pdr[-1] > 8.0                          # the drifting PDR ends far off
    assert gen.mean() < 0.75 * pdr.mean() and gen.max() < 0.75 * pdr.max()
    assert gen[-1] < 0.3 * pdr[-1]
    crumbs = {p.agent: p for p in rec.on("breadcrumbs")}
    assert set(crumbs) == set(CRUMBS)
    # breadcrumbs start at the dropping firefighter's PDR position (drifting) and are
    # pulled by every later encounter: they stay within a few metres
    final = np.array([np.hypot(*(crumbs[bc].position[:2] - xy)) for bc, xy in CRUMBS.items()])
    assert final.mean() < 3.5 and final.max() < 6.0
    assert all(crumbs[bc].cov[0, 0] > 0 for bc in CRUMBS)


def test_marginalisation_window_is_exact_for_linear_edges():
    """§IV-E: deleting old states (eq. 17) changes nothing for linear edges: a window of 3
    states gives the same poses as keeping every state (the paper's position-only GEN,
    whose edges here are all linear)."""
    msgs, truth, _ = walk(laps=2)
    short = run_component(BreadcrumbGenEstimator, {**PAPER, "graph": {"window": 3}}, msgs)
    full = run_component(BreadcrumbGenEstimator, {**PAPER, "graph": {"window": 10_000}}, msgs)
    a = np.array([p.position for p in short.on("pose")])
    b = np.array([p.position for p in full.on("pose")])
    np.testing.assert_allclose(a, b, atol=1e-8)
    ca = np.array([p.cov for p in short.on("pose")])
    cb = np.array([p.cov for p in full.on("pose")])
    np.testing.assert_allclose(ca, cb, atol=1e-8)


def test_heading_states_learn_the_gyro_drift():
    """A heading drifting at a constant rate (a residual gyro bias) is a rotation the
    position-only GEN cannot express: with heading states the loop closures at the base
    and the breadcrumbs estimate the drift rate, and the track stays far closer."""
    drift = 10.0                                       # [deg per lap of 100 s]
    msgs, truth, t = walk(laps=4, drift_deg_per_lap=drift)
    ours = run_component(BreadcrumbGenEstimator, PARAMS, msgs)
    paper = run_component(BreadcrumbGenEstimator, PAPER, msgs)
    e_ours, e_paper = errors(ours, truth), errors(paper, truth)
    later = t > 110.0                                  # after the first loop closure
    assert e_ours[later].max() < 0.5 * e_paper[later].max()
    assert e_ours[later].mean() < 1.0
    # the published heading: the odometry's (0 here) plus the estimated correction, which
    # must undo the simulated drift psi(t) = drift * (t - 10) / 100 s
    poses = ours.on("pose")
    psi_true = -np.radians(drift) * (t - 10.0) / 100.0
    heading = np.array([p.heading for p in poses])
    err = np.degrees(np.abs(np.angle(np.exp(1j * (heading - psi_true)))))
    assert np.all(err[later] < 3.0)
    sigma = np.degrees(np.sqrt([p.cov[3, 3] for p in poses]))
    assert np.all(err[later] < 3.0 * sigma[later])      # its variance is not optimistic
    assert sigma[later].max() < 0.5 * sigma[~later].max()   # and shrinks at the closures


def states_in_graph(params: dict, msgs) -> tuple[np.ndarray, np.ndarray, object]:
    """(times, firefighter states in the graph after each step, component)."""
    comp, _, _ = make_component(BreadcrumbGenEstimator, params)
    comp.start()
    t, n = [], []
    for s, m in msgs:
        comp.handle(s, m)
        if s == "odo":
            keys = [str(k) for k in comp.gen.nodes if str(k).startswith("ff1@")]
            assert sum(k.endswith("/heading") for k in keys) in (0, len(keys) // 2)
            t.append(m.t)
            n.append(sum(not k.endswith("/heading") for k in keys))
    return np.array(t), np.array(n), comp


def test_graph_keeps_the_window_and_the_states_with_unsettled_headings():
    """§IV-E window; with heading states, a state whose heading is still uncertain (the
    first lap, before the loop closes at the base at t = 110 s) is not marginalised until
    a closure settles it, and never more than ``window_max`` are kept. The settled backlog
    goes at most ``forget_per_update`` (4) states per update: at most 3 fewer per step."""
    msgs, _, _ = walk(laps=2)
    t, n, _ = states_in_graph({**PAPER, "graph": {"window": 5}}, msgs)
    assert np.all(n[4:] == 5)
    # heading priors of a calibrated INS, as the walk's drift is (10 deg per lap): the
    # closure then settles the first lap's headings below graph.settle_heading_sigma
    calibrated = {**PARAMS, "heading": {"rate_sigma": 0.009, "rate_walk": 1e-4}}
    t, n, comp = states_in_graph({**calibrated, "graph": {"window": 5}}, msgs)
    before = n[t < 110]
    assert before.max() > 80                           # the whole first lap is kept ...
    k0 = len(before)
    drained = k0 + int(np.argmax(n[k0:] == 5))         # ... until the closure settles it
    assert n[drained] == 5 and before[-1] / 3 <= drained - k0 < 80
    assert np.all(np.diff(n[k0 - 1:drained + 1]) >= -3)
    assert n[drained:].max() < 0.5 * before.max()      # later breadcrumbs settle sooner
    assert comp.ctx.stats.counts[comp.ctx.id]["states_kept_unsettled"] > 0
    _, n, _ = states_in_graph({**calibrated, "graph": {"window": 5, "window_max": 30}}, msgs)
    assert n.max() == 30


def test_impossible_speed_is_dropped():
    """§IV-F: a 30 m step in one second is physically impossible (> 5 m/s)."""
    msgs, truth, _ = walk(laps=1, drift_deg_per_lap=0.0)
    k = next(i for i, (s, m) in enumerate(msgs) if s == "odo" and i >= 20)
    s, bad = msgs[k]
    msgs[k] = (s, Odometry(t=bad.t, agent="ff1", t_start=bad.t_start, delta=bad.delta + [30, 0, 0],
                           dheading=0.0, cov=bad.cov, position=bad.position, heading=0.0))
    comp, rec, stats = make_component(BreadcrumbGenEstimator, PARAMS)
    comp.start()
    for s, m in msgs:
        comp.handle(s, m)
    assert stats.counts["under_test"]["odometry_too_fast"] == 1
    est = np.array([p.position for p in rec.on("pose")])
    assert np.max(np.hypot(*(est[:, :2] - truth[:len(est), :2]).T)) < 6.0
    assert any(d.code == "odometry_too_fast" for d in rec.on("diagnostics"))


def test_kicked_breadcrumb_becomes_a_new_node():
    """§V-C: after a kick (1.5 m) the breadcrumb is re-estimated at its new place."""
    msgs, truth, _ = walk(laps=4, drift_deg_per_lap=2.0, kick=True)
    rec = run_component(BreadcrumbGenEstimator, PARAMS, msgs)
    last = [p for p in rec.on("breadcrumbs") if p.agent == "bc1"][-1]
    assert last.device == "bc1#2"
    assert np.hypot(*(last.position[:2] - (21.5, 0.0))) < 1.2
    assert any(d.code == "breadcrumb_relocated" for d in rec.on("diagnostics"))


def test_bad_input_is_counted_not_raised():
    msgs, _, _ = walk(laps=1)
    odo = msgs[0][1]
    comp, rec, stats = make_component(BreadcrumbGenEstimator, PARAMS)
    comp.start()
    comp.handle("odo", Odometry(t=1.0, agent="ff1", t_start=0.5, delta=np.array([np.nan, 0, 0]),
                                dheading=0.0, cov=odo.cov, position=odo.position, heading=0.0))
    for s, m in msgs[:20]:
        comp.handle(s, m)
    comp.handle("r", Range(t=25.0, agent="ff1", a="ff1", b="nobody", range_m=2.0, sigma_m=0.5,
                           method="rssi"))
    comp.handle("r", Range(t=25.0, agent="ff1", a="ff1", b="base", range_m=-2.0, sigma_m=0.5,
                           method="rssi"))
    comp.handle(*msgs[20])
    comp.finish()
    c = stats.counts["under_test"]
    assert c["bad_odometry"] == 1 and c["radio_unmatched"] == 1 and c["range_invalid"] == 1
    assert len(rec.on("pose")) == sum(s == "odo" for s, _ in msgs[:21])


def test_needs_a_base_position():
    comp, _, _ = make_component(BreadcrumbGenEstimator, {})
    with pytest.raises(ValueError, match="base.position"):
        comp.start()


def test_conforms_to_the_plugin_contract():
    msgs, _, _ = walk(laps=1)
    check_plugin(BreadcrumbGenEstimator, PARAMS, sample_input=[m for m in msgs[:30]])


def test_events_of_a_firefighter_without_odometry_are_counted_and_reported():
    """ff2's odometry is all bad: its breadcrumb drop and range cannot be placed; they are
    counted and reported at the end, not silently dropped."""
    msgs, _, _ = walk(laps=1)
    odo = msgs[0][1]
    comp, rec, stats = make_component(BreadcrumbGenEstimator, PARAMS)
    comp.start()
    comp.handle("odo", Odometry(t=1.0, agent="ff2", t_start=0.5, delta=np.array([np.nan, 0, 0]),
                                dheading=0.0, cov=odo.cov, position=odo.position, heading=0.0))
    comp.handle("r", Range(t=2.0, agent="ff2", a="ff2", b="base", range_m=2.0, sigma_m=0.5,
                           method="rssi"))
    comp.handle("d", BreadcrumbDrop(t=3.0, agent="ff2", node_id="bc9"))
    comp.finish()
    assert stats.counts["under_test"]["events_without_odometry"] == 2
    (d,) = [m for m in rec.on("diagnostics") if m.code == "no_odometry"]
    assert d.agent == "ff2" and "2 radio/drop" in d.text
