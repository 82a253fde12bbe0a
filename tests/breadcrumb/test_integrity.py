"""Integrity of breadcrumb_gen (issue 15 item 1) and the path-loss model it learns online:
protection radius and trust derived from the published covariance, a contradicting radio
link down-weighted, counted, said with the place and widening."""
from __future__ import annotations

import math

import numpy as np

from firenav_framework import BreadcrumbDrop, Odometry, Range
from firenav_framework.integrity import gaussian_protection_radius
from firenav_framework.testing import run_component
from firenav_plugins.estimators.breadcrumb_gen import BreadcrumbGenEstimator
from firenav_plugins.estimators.breadcrumb_gen.radio_model import PathLossLearner
from tests.breadcrumb.test_estimator import PARAMS, errors, walk


def test_protection_radius_and_trust_come_from_the_published_covariance():
    msgs, truth, _ = walk(laps=3, drift_deg_per_lap=10.0)
    # the graph's odometry model is right here (the drift is the heading states' own), so
    # its covariance is honest as it is; the doubt beside it has its own test below
    rec = run_component(BreadcrumbGenEstimator,
                        {**PARAMS, "consistency": {"doubt_per_m": 0.0}}, msgs)
    poses = rec.on("pose")
    pr = np.array([p.protection_radius for p in poses])
    expect = np.array([gaussian_protection_radius(p.cov[:2, :2], 0.99) for p in poses])
    np.testing.assert_allclose(pr, expect)
    assert np.all(np.isfinite(pr))
    trusted = np.array([p.trusted for p in poses])
    np.testing.assert_array_equal(trusted, pr <= 3.0)
    err = errors(rec, truth)
    assert np.mean(err <= pr) >= 0.95                 # the 99 % bound holds (with slack)
    assert not np.any(trusted & (err > 3.0))          # never trusted while > 3 m off
    assert trusted.sum() >= 10                        # and it is not simply never trusted
    crumbs = rec.on("breadcrumbs")
    assert all(math.isfinite(c.protection_radius) for c in crumbs)


def contradicted(params: dict):
    """The loop with one false encounter 15 m from the firefighter at t = 60 s."""
    msgs, truth, t = walk(laps=2, drift_deg_per_lap=2.0)
    k = next(i for i, (s, m) in enumerate(msgs) if s == "odo" and m.t >= 60.0)
    at = msgs[k][1].t
    msgs.insert(k + 1, ("enc", Range(t=at, agent="ff1", a="ff1", b="base", range_m=0.8,
                                     sigma_m=1.0, method="rssi_encounter")))
    rec = run_component(BreadcrumbGenEstimator, params, msgs)
    return rec, truth, t, at


def test_a_contradicting_link_is_down_weighted_counted_said_and_widens():
    rec, truth, t, at = contradicted(PARAMS)
    clean = run_component(BreadcrumbGenEstimator, PARAMS, walk(laps=2, drift_deg_per_lap=2.0)[0])
    # the truth at t = 60 s is 10-20 m from the base: the encounter contradicts the graph
    assert np.hypot(*truth[np.searchsorted(t, at), :2]) > 10.0
    said = [d for d in rec.on("diagnostics") if d.code == "radio_contradiction"]
    assert len(said) == 1 and "near (" in said[0].text and said[0].agent == "ff1"
    poses, ref = rec.on("pose"), clean.on("pose")
    k = next(i for i, p in enumerate(poses) if p.t > at)
    # down-weighted: the pose moves by far less than the 10+ m the link claims
    assert np.hypot(*(poses[k].position[:2] - ref[k].position[:2])) < 1.5
    # widened and not trusted until consistent links return
    assert poses[k].protection_radius > ref[k].protection_radius + 10.0
    assert not poses[k].trusted
    assert poses[-1].protection_radius < 1.5 * ref[-1].protection_radius
    # the paper's rule (consistency off) drops it: no widening
    paper = {**PARAMS, "consistency": {"enabled": False}}
    rec2, _, _, _ = contradicted(paper)
    p2 = rec2.on("pose")
    ref2 = run_component(BreadcrumbGenEstimator, paper,
                         walk(laps=2, drift_deg_per_lap=2.0)[0]).on("pose")
    assert abs(p2[k].protection_radius - ref2[k].protection_radius) < 0.2


def test_path_loss_model_is_learned_from_links_of_known_length():
    """Sensor model -40 dBm at 1 m, exponent 3; the building's -44 dBm, 2.2, with 4 dB
    shadowing: the learned line gives the building's exponent and RSSI at 1 m."""
    rng = np.random.default_rng(3)
    p0, n0, p_true, n_true = -40.0, 3.0, -44.0, 2.2
    learner = PathLossLearner(0.15, 0.3, 0.2, min_samples=20)
    d = rng.uniform(1.1, 8.0, 400)
    rssi = p_true - 10 * n_true * np.log10(d) + rng.normal(0, 4.0, len(d))
    r_sensor = 10 ** ((p0 - rssi) / (10 * n0))
    assert not learner.ready and learner.correct(2.0, 0.5) == (2.0, 0.5)
    for rs, dk in zip(r_sensor, d):
        learner.observe(rs, dk)
    n, p1 = learner.exponent_and_rssi_1m(n0, p0)
    assert abs(n - n_true) < 0.25 and abs(p1 - p_true) < 1.5
    # corrected near ranges (the ones the graph uses) are unbiased in log; the sensor's
    # were 20 % long
    corr = np.array([learner.correct(rs, 0.3 * rs)[0] for rs in r_sensor])
    near = d < 1.6
    assert abs(np.median(np.log10(corr[near] / d[near]))) < 0.04
    assert np.median(np.log10(r_sensor[near] / d[near])) > 0.06


def pair_walk(period: float = 2.0, steps: int = 60):
    """Two firefighters walking east side by side from the base, 1 m a second, each with
    its own odometry noise, an encounter between them every ``period`` seconds and no
    other radio link."""
    from firenav_framework import Odometry
    rng = np.random.default_rng(5)
    msgs = []
    pos = {"ff1": np.array([0.5, 0.0, 0.0]), "ff2": np.array([0.5, 0.5, 0.0])}
    for k in range(1, steps + 1):
        t = 10.0 + k
        for ff in ("ff1", "ff2"):
            dm = np.array([1.0, 0.0, 0.0]) + rng.normal(0, 0.02, 3)
            pos[ff] = pos[ff] + dm
            msgs.append(("odo", Odometry(t=t, agent=ff, device=f"{ff}/ins", t_start=t - 1.0,
                                         delta=dm, dheading=0.0,
                                         cov=np.diag([4e-4] * 3 + [1e-4]),
                                         position=pos[ff].copy(), heading=0.0)))
        if k % int(period) == 0:
            msgs.append(("enc", Range(t=t, agent="ff1", a="ff1", b="ff2", range_m=0.8,
                                      sigma_m=1.0, method="rssi_encounter")))
    return msgs


def relative_variance(params: dict) -> tuple[float, float, dict]:
    """(variance of x_ff1 - x_ff2 along x at the end [m^2], ff1's running normalised
    innovation, counts) after the pair walk."""
    from firenav_framework.testing import make_component
    comp, _, stats = make_component(BreadcrumbGenEstimator, params)
    comp.start()
    for s, m in pair_walk():
        comp.handle(s, m)
    a, b = comp._agents["ff1"].states[-1].key, comp._agents["ff2"].states[-1].key
    c = comp.gen.joint_covariance([a, b])
    return float(c[0, 0] + c[3, 3] - 2 * c[0, 3]), comp._agents["ff1"].nis, \
        stats.counts["under_test"]


def test_repeated_links_between_two_firefighters_are_not_independent_evidence():
    """Issue 15 (field fire floor): team A's two firefighters exchange encounters all the
    time; counted as independent, 30 of them in a minute pin the pair together 30 times
    over and agree with the graph wherever the pair has drifted. Within
    ``radio.mutual_correlation_s`` they share one error: in steady contact they carry
    about one link's information per window, and they never count as a check of the
    graph (the running normalised innovation stays where it was)."""
    shared, nis, counts = relative_variance({**PARAMS})
    independent, nis_ind, _ = relative_variance(
        {**PARAMS, "radio": {"mutual_correlation_s": 0.0}})
    one_link = 1.0 ** 2                       # an encounter's sigma per axis, squared
    assert independent < one_link / 5        # many independent links (through odometry)
    assert shared > 3 * independent
    assert shared > one_link / 4              # about one link's worth
    assert counts["mutual_links_shared"] >= 25
    assert nis == 1.0                         # untouched by mutual links
    assert nis_ind == 1.0



def waiting_near_the_base(params: dict, wait_s: int = 300):
    """Issue 15 (field fire floor, tuning seed 108): a firefighter walks 3.6 m east of the
    base station and waits there; the odometry is right. Of the many range readings from
    that far, fast fading lets the short ones through: one of 1.3 m every second, every
    one saying "next to the base". Returns (the last pose, its horizontal error [m])."""
    from firenav_framework import Odometry
    msgs, pos = [], np.zeros(3)
    for k in range(1, wait_s + 1):
        t = 10.0 + k
        dm = np.array([0.9 if k <= 4 else 0.0, 0.0, 0.0])
        pos = pos + dm
        msgs.append(("odo", Odometry(t=t, agent="ff1", device="ff1/ins", t_start=t - 1.0,
                                     delta=dm, dheading=0.0, cov=np.diag([4e-4] * 3 + [1e-4]),
                                     position=pos.copy(), heading=0.0)))
        if k > 4:
            msgs.append(("range", Range(t=t, a="ff1", b="base", range_m=1.3, sigma_m=0.6,
                                        method="rssi")))
    last = run_component(BreadcrumbGenEstimator, params, msgs).on("pose")[-1]
    return last, np.array([3.6, 0.0]) - last.position[:2]


def test_short_readings_from_one_place_do_not_make_a_wrong_pose_trusted():
    """Old rules (every range used, a near range as tight as its reading): the waiting
    firefighter is pulled onto the base and trusted while 3.6 m off, far outside its 95 %
    ellipse. Now the ranges from one place count once (``radio.shadow_length``) and a
    near range spreads at least ``radio.near_sigma`` per axis: not trusted while off, and
    the truth inside the ellipse."""
    base = {"base": {"position": [0.0, 0.0, 0.0]}, "learn": {"enabled": False}}
    old = {**base, "radio": {"shadow_length": 0.0, "near_sigma": 0.0}}
    for params, wrong in ((base, False), (old, True)):
        pose, err = waiting_near_the_base(params)
        m2 = float(err @ np.linalg.solve(pose.cov[:2, :2], err))
        off = np.hypot(*err) > 3.0
        if wrong:
            assert off and pose.trusted and m2 > 5.99
        else:
            assert not (off and pose.trusted) and m2 <= 5.99


def walk_with_short_steps(scale: float = 0.92):
    """Issue 15 (field fire floor): an error the graph's odometry model cannot represent.
    A firefighter walks 40 m east of the base station in 1 m steps, drops bc1 at 10 m,
    walks back to it (an encounter there and 1 m on) and on 5 m; the INS measures every step
    ``scale`` of its length and says it is good to 2 cm. Returns (messages, the true x
    [m] of each pose, the distance walked by the odometry at each pose [m])."""
    xs = [float(k) for k in range(1, 41)] + [float(x) for x in range(39, 4, -1)]
    msgs, pos, prev, walked = [], np.zeros(3), 0.0, []
    for k, x in enumerate(xs):
        t = 10.0 + k
        dm = np.array([(x - prev) * scale, 0.0, 0.0])
        pos, prev = pos + dm, x
        walked.append(abs(dm[0]) + (walked[-1] if walked else 0.0))
        msgs.append(("odo", Odometry(t=t, agent="ff1", device="ff1/ins", t_start=t - 1.0,
                                     delta=dm, dheading=0.0, cov=np.diag([4e-4] * 3 + [1e-4]),
                                     position=pos.copy(), heading=0.0)))
        if x == 10.0 and k < 40:
            msgs.append(("drops", BreadcrumbDrop(t=t, agent="ff1", device="ff1/dispenser",
                                                 node_id="bc1")))
        elif x in (10.0, 9.0):
            msgs.append(("enc", Range(t=t, agent="ff1", a="ff1", b="bc1", range_m=0.5,
                                      sigma_m=1.0, method="rssi_encounter")))
    return msgs, np.array(xs), np.array(walked)


def test_the_doubt_grows_with_the_distance_walked_whatever_the_odometry_model_says():
    """The INS's steps are 8 % short: 3.2 m off after 40 m, while the graph, believing
    the INS's 2 cm and ``odometry.noise_per_m`` (position-only states), says about 0.6 m
    per axis and trusts the pose. The doubt (``consistency.doubt_per_m``, 0.1 by default),
    computed by hand: its std grows from the start's 0.5 m by 0.1 m per metre walked, bc1
    inherits it at the drop (plus the drop's 0.3 m squared), and each encounter at bc1
    fuses it with that plus the encounter's 1 m squared, but not below bc1's own (the
    second would fuse it below). It is added to the graph's covariance and moves
    nothing."""
    msgs, x, walked = walk_with_short_steps()
    base = {"base": {"position": [0.0, 0.0, 0.0]}, "learn": {"enabled": False},
            "radio": {"near_sigma": 0.6}, "odometry": {"noise_per_m": 0.05},
            "heading": {"enabled": False}}
    off = run_component(BreadcrumbGenEstimator,
                        {**base, "consistency": {"doubt_per_m": 0.0}}, msgs).on("pose")
    on = run_component(BreadcrumbGenEstimator, base, msgs).on("pose")
    sigma, expect = 0.5, []
    for k, w in enumerate(walked):
        sigma += 0.1 * (w - (walked[k - 1] if k else 0.0))
        expect.append(sigma ** 2)
        if x[k] == 10.0 and k < 40:                      # the drop
            crumb = sigma ** 2 + 0.3 ** 2
        elif k >= 40 and x[k] in (10.0, 9.0):            # at bc1, after this pose
            v = crumb + 1.0
            sigma = math.sqrt(max(sigma ** 2 * v / (sigma ** 2 + v), crumb))
    got = np.array([p.cov[0, 0] - q.cov[0, 0] for p, q in zip(on, off)])
    np.testing.assert_allclose(got, expect, rtol=1e-6)
    np.testing.assert_allclose([p.cov[1, 1] - q.cov[1, 1] for p, q in zip(on, off)], expect,
                               rtol=1e-6)
    np.testing.assert_allclose([p.position for p in on], [p.position for p in off])

    def judged(poses):
        err = np.array([p.position[0] for p in poses[:40]]) - x[:40]
        m2 = np.array([e * e / p.cov[0, 0] for e, p in zip(err, poses)])
        wrong = np.array([p.trusted for p in poses[:40]]) & (np.abs(err) > 3.0)
        return np.mean(m2 <= 5.99), wrong.any()

    assert judged(off)[1] and judged(off)[0] < 0.9       # without it: confidently wrong
    assert judged(on) == (1.0, False)
