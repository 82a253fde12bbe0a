"""The particle filter end to end on synthetic walks with drifting odometry."""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from firenav_framework import GroundTruth, Odometry
from firenav_framework.building import bundled_plan, load_building
from firenav_framework.building.search_patterns import extract_search_patterns
from firenav_framework.building.sketch import PlanSketch
from firenav_framework.capabilities import ParticleConstraint, Particles
from firenav_framework.testing import check_plugin, make_component
from firenav_plugins.constraints.search_pattern_icp import SearchPatternIcpConstraint
from firenav_plugins.constraints.wall_crossing import WallCrossingConstraint
from firenav_plugins.estimators.particle_filter import ParticleFilterEstimator
from firenav_plugins.estimators.particle_filter.map_error import SpreadMonitor
from tests.contract.known import known
from tests.pf.synthetic import drifting_walk

K99 = math.sqrt(-2.0 * math.log(0.01))   # 99 % radius of a unit 2-D Gaussian


@pytest.fixture(scope="module")
def flat():
    return load_building(bundled_plan("flat_125"))


@pytest.fixture(scope="module")
def search_walk(flat):
    """Two laps of a right-hand search of flat_125 (about 235 m, 6.7 min)."""
    sp = extract_search_patterns(flat)
    loop = sp.positions(sp.sequence("right_hand"))
    return drifting_walk(np.vstack([loop, loop, loop[:1]]), seed=11, drift_deg_per_min=8.0,
                         scale=1.04)


def pose_start(x: float, y: float, heading: float = 0.0) -> dict:
    """A known start pose (walking heading [rad])."""
    return {"mode": "pose", "position": (x, y, 0.0), "heading": heading}


def run(building, walk, params, constraints=()):
    pf, rec, stats = make_component(ParticleFilterEstimator, params, building=building)
    for k, (cls, p) in enumerate(constraints):
        c, _, _ = make_component(cls, p, building=building, cid=f"c{k}")
        c.start()
        pf.constraints.append(c)
    pf.start()
    for stream, msg in walk.messages():
        pf.handle(stream, msg)
    pf.finish()
    return rec, stats.counts["under_test"]


def errors(poses, walk):
    t = np.array([p.t for p in poses])
    est = np.array([p.position[:2] for p in poses])
    tt = np.array([g.t for g in walk.truth])
    truth = np.column_stack([np.interp(t, tt, walk.truth_xy[:, 0]),
                             np.interp(t, tt, walk.truth_xy[:, 1])])
    return t, np.hypot(*(est - truth).T)


def dead_reckoning_errors(walk):
    """Odometry alone, aligned to the true start pose and first-step direction."""
    ins = np.array([np.zeros(3)] + [o.position for o in walk.odometry])[:, :2]
    truth = walk.truth_xy
    a = (math.atan2(*(truth[1] - truth[0])[::-1]) - math.atan2(*(ins[1] - ins[0])[::-1]))
    r = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    return np.hypot(*(((ins - ins[0]) @ r.T + truth[0]) - truth).T)[1:]


def test_walls_beat_odometry_alone_from_a_known_start(flat, search_walk):
    rec, counts = run(flat, search_walk, {"particles": 300, "start": {"mode": "truth"}, "seed": 1},
                      [(WallCrossingConstraint, {})])
    _, err = errors(rec.on("pose"), search_walk)
    dr = dead_reckoning_errors(search_walk)
    rmse, dr_rmse = math.sqrt(np.mean(err ** 2)), math.sqrt(np.mean(dr ** 2))
    assert dr_rmse > 2.0            # the drift model really does drift
    assert rmse < 0.5 * dr_rmse and rmse < 1.0
    assert counts["replaced_particles"] > 0


def test_search_patterns_find_an_unknown_start_where_walls_alone_do_not(flat, search_walk):
    """§V-C, Fig. 8 (b): without prior on the start, the conventional filter (walls only)
    loses itself; with pseudo-observations and resampling it settles to about 1 m."""
    params = {"particles": 500, "start": {"mode": "unknown"}, "seed": 2}
    rec, counts = run(flat, search_walk, params,
                      [(WallCrossingConstraint, {}), (SearchPatternIcpConstraint, {})])
    walls_only, _ = run(flat, search_walk, params, [(WallCrossingConstraint, {})])
    poses = rec.on("pose")
    t, err = errors(poses, search_walk)
    late = t > t[0] + 150.0       # the paper's ~2.5 min settling time
    rmse = math.sqrt(np.mean(err[late] ** 2))
    t2, err2 = errors(walls_only.on("pose"), search_walk)
    rmse_walls = math.sqrt(np.mean(err2[t2 > t2[0] + 150.0] ** 2))
    assert rmse < 1.2 and rmse_walls > 3 * rmse
    # trusted from the cloud's protection radius (<= 3 m): mostly once settled, hardly ever
    # while off by more than 3 m (the 2 %), and the radius holds the error
    trusted = np.array([p.trusted for p in poses])
    radius = np.array([p.protection_radius for p in poses])
    assert np.mean(trusted[late]) > 0.8
    assert np.mean(trusted & (err > 3.0)) <= 0.02
    assert np.mean(err[late] <= radius[late]) > 0.95
    assert not poses[0].trusted   # spread over the whole flat at first
    assert counts["injected_particles"] > 0


class Disturb(ParticleConstraint):
    """Scatters the cloud over a 10 m square at t1 and gathers it again at t2."""

    name = "disturb"

    def __init__(self, params, ctx, t1=20.0, t2=40.0):
        super().__init__(params, ctx)
        self.t1, self.t2 = t1, t2

    def replacements(self, step):
        n = len(step.particles)
        if step.t >= self.t1 and not hasattr(self, "spread"):
            self.spread = True
            return Particles.create(step.rng.uniform(0, 10, (n, 2)), step.particles.yaw)
        if step.t >= self.t2 and not hasattr(self, "gathered"):
            self.gathered = True
            return Particles.create(np.full((n, 2), 5.0), step.particles.yaw)
        return None


def straight_walk(n=60, agent="ff1", step_m=0.05):
    """``n`` odometry increments of ``step_m`` [m] east, one a second."""
    out, pos = [], np.zeros(3)
    for k in range(1, n + 1):
        delta = np.array([step_m, 0.0, 0.0])
        pos = pos + delta
        out.append(Odometry(t=float(k), agent=agent, t_start=k - 1.0, delta=delta, dheading=0.0,
                            cov=np.eye(4) * 1e-4, position=pos.copy(), heading=0.0))
    return out


class RecordOdometry(ParticleConstraint):
    """Keeps the odometry of every step the filter hands its constraints."""

    name = "record_odometry"

    def replacements(self, step):
        self.seen = [*getattr(self, "seen", []), step.odometry]
        return None


def test_steps_summed_over_the_update_interval_keep_the_ins_drift_rate(flat):
    """Odometry summed to the update interval (2 s here: two 1 s steps a filter step) is
    one merged message; it still carries the INS's ``yaw_drift_rate_sigma`` (a property
    of the INS, not of the summing), and its span and displacement are the two steps'."""
    pf, _, _ = make_component(ParticleFilterEstimator,
                              {"start": pose_start(5.0, 5.0), "update_interval": 2.0},
                              building=flat)
    rec = make_component(RecordOdometry, {}, building=flat, cid="rec")[0]
    pf.constraints.append(rec)
    sigma = np.radians(0.17)
    for msg in straight_walk(4):
        pf.handle("odo", replace(msg, yaw_drift_rate_sigma=sigma))
    assert [(o.t_start, o.t) for o in rec.seen] == [(0.0, 2.0), (2.0, 4.0)]
    np.testing.assert_allclose([o.delta[0] for o in rec.seen], [0.1, 0.1])
    assert all(o.yaw_drift_rate_sigma == sigma for o in rec.seen)


def test_map_error_diagnostic_fires_above_3_m2_and_clears(flat):
    pf, rec, _ = make_component(ParticleFilterEstimator, {"start": pose_start(5.0, 5.0)},
                                building=flat)
    pf.constraints.append(make_component(Disturb, {}, building=flat, cid="disturb")[0])
    for msg in straight_walk():
        pf.handle("odo", msg)
    diags = [(d.t, d.code, d.level, d.active) for d in rec.on("diagnostics")]
    assert diags == [(20.0, "map_error", "warning", True), (40.0, "map_error", "info", False)]
    trusted = {p.t: p.trusted for p in rec.on("pose")}
    spread = {p.t: p.cov[0, 0] + p.cov[1, 1] for p in rec.on("pose")}
    assert spread[20.0] > 3.0 and spread[19.0] < 3.0 and spread[40.0] < 3.0
    assert trusted[19.0] and not trusted[20.0] and not trusted[39.0] and trusted[40.0]


def test_spread_monitor_periods():
    """§V-E: converging, converged, disturbed (map error), converged again."""
    m = SpreadMonitor(3.0)
    seq = [10.0, 5.0, 2.9, 1.0, 3.5, 8.0, 2.0, 4.0]
    events = [m.update(v) for v in seq]
    assert events == [None, None, None, None, "map_error", None, "recovered", "map_error"]
    hyst = SpreadMonitor(3.0, clear_m2=1.0)
    assert [hyst.update(v) for v in (0.5, 4.0, 2.0, 0.9)] == [None, "map_error", None, "recovered"]


def test_bad_odometry_is_counted_and_skipped(flat):
    pf, rec, stats = make_component(ParticleFilterEstimator, {"start": pose_start(5, 5)},
                                    building=flat)
    good = straight_walk(3)
    bad = Odometry(t=2.5, agent="ff1", t_start=2.0, delta=np.array([np.nan, 0, 0]), dheading=0.0,
                   cov=np.eye(4), position=np.zeros(3), heading=0.0)
    for msg in (good[0], good[1], bad, good[1], good[2]):
        pf.handle("odo", msg)
    counts = stats.counts["under_test"]
    assert counts["bad_odometry"] == 1 and counts["stale_odometry"] == 1
    assert [d.code for d in rec.on("diagnostics")] == ["bad_odometry"]
    assert len(rec.on("pose")) == 3


def test_configuration_errors_are_specific(flat):
    with pytest.raises(ValueError, match="mode 'pose' needs a position"):
        make_component(ParticleFilterEstimator, {"start": {"mode": "pose"}}, building=flat)
    with pytest.raises(ValueError, match="read only with mode 'pose'"):
        make_component(ParticleFilterEstimator, {"start": {"position": (1, 1, 0)}}, building=flat)
    pf, _, _ = make_component(ParticleFilterEstimator,
                              {"start": {"mode": "entrance", "entrance": "back_door"}},
                              building=flat)
    with pytest.raises(ValueError, match="no entrance 'back_door'"):
        pf.handle("odo", straight_walk(1)[0])


def test_entrance_start_and_truth_start(flat):
    rec, _ = run(flat, drifting_walk(np.array([[0.5, 4.9], [6.0, 4.9]]), seed=3),
                 {"start": {"mode": "entrance", "sigma_heading": "30 deg"},
                  "particles": 200})
    first = rec.on("pose")[0]
    assert np.hypot(*(first.position[:2] - [0.0, 4.9])) < 1.5
    walk = drifting_walk(np.array([[3.0, 2.0], [3.0, 3.5]]), seed=3)
    rec, _ = run(flat, walk, {"start": {"mode": "truth"}, "particles": 200})
    assert np.hypot(*(rec.on("pose")[0].position[:2] - walk.truth_xy[1])) < 0.5


def two_storeys(name: str, room: tuple[float, float, float, float],
                stair: list[tuple[float, float]]):
    """Two storeys 3 m apart with the same room ``room`` (x0, y0, x1, y1) [m] on each and a
    stair along ``stair`` from the ground floor to the first."""
    sk = PlanSketch(name)
    for level in range(2):
        f = sk.floor(3.0 * level, 3.0)
        f.room(f"r{level}", room)
    sk.floors[0].stair("s", stair, floor_to=1, width=1.2)
    return sk.build()


def test_floor_changes_on_the_stair():
    b = two_storeys("stairs", (0, 0, 10, 4), [(2, 2), (8, 2)])
    pf, rec, _ = make_component(ParticleFilterEstimator, {"start": pose_start(1.5, 2.0),
                                                          "particles": 200,
                                                          "motion": {"position_noise": 0.02}},
                                building=b)
    pos = np.zeros(3)
    for k in range(1, 9):            # 8 x 0.8 m up the 6 m stair, rising 3 m
        delta = np.array([0.8, 0.0, 0.4 if 1 < k < 9 else 0.0])
        pos = pos + delta
        pf.handle("odo", Odometry(t=float(k), agent="ff1", t_start=k - 1.0, delta=delta,
                                  dheading=0.0, cov=np.eye(4) * 1e-4, position=pos.copy(),
                                  heading=0.0))
    floors = [p.floor for p in rec.on("pose")]
    assert floors[0] == 0 and floors[-1] == 1
    assert rec.on("pose")[-1].position[2] == pytest.approx(3.0, abs=0.5)


def _two_storeys_with_a_stair():
    sk = PlanSketch("stairs")
    for level in range(2):
        f = sk.floor(3.0 * level, 3.0)
        f.room(f"r{level}", (0, 0, 10, 8))
    sk.floors[0].stair("s", [(2, 2), (8, 2)], floor_to=1, width=1.2)   # footprint y 1.4-2.6
    return sk.build()


@pytest.mark.parametrize("margin, y, expected", [
    (0.0, 2.0, 1),     # on the footprint: climbs
    (0.0, 3.0, 0),     # 0.4 m beside it: the climb is reset at every update
    (1.0, 3.0, 1),     # ... unless within the margin
    (1.0, 6.0, 0),     # 3.4 m away: vertical drift never changes the floor
])
def test_stair_margin_lets_a_particle_beside_the_flight_finish_its_climb(margin, y, expected):
    from firenav_plugins.estimators.particle_filter.stairs import StairRegions
    regions = StairRegions(_two_storeys_with_a_stair(), margin)
    p = Particles.create(np.column_stack([np.linspace(2.5, 7.5, 50), np.full(50, y)]), 0.0)
    changes = sum(regions.apply(p, 0.3) for _ in range(8))    # 2.4 m up in 0.3 m steps
    assert np.all(p.floor == expected)
    assert changes == (50 if expected else 0)
    # the climb beyond half the rise is kept on the new floor: 2.4 - 3.0 m
    assert np.allclose(p.climb, -0.6 if expected else 0.0)


def test_plugin_conformance(flat):
    check_plugin(ParticleFilterEstimator, {"particles": 50}, sample_input=[("odo", m) for m in straight_walk(4)]
                 + [("truth", GroundTruth(t=5.0, agent="ff1", position=np.zeros(3)))],
                 building=flat, exclude=known("estimator", "particle_filter"))
    check_plugin(WallCrossingConstraint)
    check_plugin(SearchPatternIcpConstraint, exclude=known("constraint", "search_pattern_icp"))


@pytest.mark.parametrize("noise_while_still", [True, False])
def test_standing_still_spreads_the_cloud_only_with_noise_while_still(flat, noise_while_still):
    """A minute at rest (ZUPT 'still' increments of a few mm): the paper's 2 Hz noise
    spreads the cloud over the room; without it the cloud keeps its start spread and
    moves by the increments alone."""
    start = np.array([2.2, 2.0])                       # middle of the bedroom at the origin
    pf, rec, _ = make_component(ParticleFilterEstimator, {"start": pose_start(*start),
                                                 "particles": 400,
                                                          "motion": {"noise_while_still":
                                                                     noise_while_still}},
                                building=flat)
    pf.constraints.append(make_component(WallCrossingConstraint, {}, building=flat, cid="walls")[0])
    pos, delta = np.zeros(3), np.array([0.002, 0.0, 0.0])
    for k in range(1, 61):
        pos = pos + delta
        pf.handle("odo", Odometry(t=float(k), agent="ff1", t_start=k - 1.0, delta=delta,
                                  dheading=0.0, cov=np.eye(4) * 1e-6, position=pos.copy(),
                                  heading=0.0, motion="still"))
    first, last = rec.on("pose")[0], rec.on("pose")[-1]
    spread = last.cov[0, 0] + last.cov[1, 1]
    if noise_while_still:       # 120 paper updates: 1.3 m per axis before the walls cut it
        assert spread > 1.0
    else:
        # the 0.12 m it moved, turned by each particle's +-5 deg frame rotation
        assert spread == pytest.approx(first.cov[0, 0] + first.cov[1, 1], abs=1e-3)
        np.testing.assert_allclose(last.position[:2] - first.position[:2], [0.118, 0.0],
                                   atol=2e-3)


def test_yaw_rate_state_follows_an_uncalibrated_gyro(flat, search_walk):
    """An INS turning at 15 deg/min (a yaw gyro turn-on bias of 0.25 deg/s): with a
    per-particle drift rate the walls select the particles turning with it; the cloud's
    rate turns the right way (part of the drift is taken by the heading noise) and the
    track beats the filter without the rate state."""
    sp = extract_search_patterns(flat)
    loop = sp.positions(sp.sequence("right_hand"))
    walk = drifting_walk(np.vstack([loop, loop, loop[:1]]), seed=5, drift_deg_per_min=15.0)
    rmse: dict[float, float] = {}
    for sigma in (0.0, 0.3):
        pf, rec, _ = make_component(ParticleFilterEstimator, {
            "particles": 500, "start": {"mode": "truth"}, "seed": 3,
            "motion": {"yaw_rate_sigma": f"{sigma} deg/s"}}, building=flat)
        pf.constraints.append(make_component(WallCrossingConstraint, {}, building=flat, cid="walls")[0])
        for stream, msg in walk.messages():
            pf.handle(stream, msg)
        _, err = errors(rec.on("pose"), walk)
        rmse[sigma] = math.sqrt(np.mean(err ** 2))
        p = pf.state["ff1"].particles
        mean_rate = math.degrees(float(p.weights @ p.yaw_rate))
    # frame rotation = building heading - INS heading: it turns at -15 deg/min
    assert -0.4 < mean_rate < -0.08
    assert rmse[0.3] < rmse[0.0] and rmse[0.3] < 1.0


class Teleport(ParticleConstraint):
    """Moves the whole cloud, tight, 6 m east at t1: a switch to a look-alike room."""

    name = "teleport"

    def replacements(self, step):
        if step.t >= 20.0 and not hasattr(self, "done"):
            self.done = True
            n = len(step.particles)
            xy = step.particles.xy + np.array([6.0, 0.0])
            return Particles.create(xy, step.particles.yaw, np.zeros(n, int))
        return None


@pytest.mark.parametrize("jump", [None, 2.0])
def test_a_jump_between_hypotheses_is_reported_and_not_trusted_until_evidence(flat, jump):
    params = {"start": pose_start(5.0, 5.0), "injection": {"weight": "uniform"},
              "motion": {"position_noise": 0.01},
              "trust": {"jump": jump, "jump_evidence": 1.0}}
    pf, rec, stats = make_component(ParticleFilterEstimator, params, building=flat)
    pf.constraints.append(make_component(Teleport, {}, building=flat, cid="teleport")[0])
    for msg in straight_walk(80):
        pf.handle("odo", msg)
    poses = {p.t: p for p in rec.on("pose")}
    assert poses[21.0].position[0] - poses[19.0].position[0] == pytest.approx(6.1, abs=0.3)
    jumps = [(d.t, d.level) for d in rec.on("diagnostics") if d.code == "hypothesis_jump"]
    if jump is None:                   # without the rule: trusted straight after the jump
        assert jumps == [] and poses[19.0].trusted and poses[21.0].trusted
        return
    assert jumps == [(20.0, "warning")]
    assert "(6.0, 5.0) to (12.0, 5.0)" in [d.text for d in rec.on("diagnostics")
                      if d.code == "hypothesis_jump"][0]
    assert poses[19.0].trusted
    # 0.05 m per update: untrusted until 1 m has been walked since the jump
    assert not any(poses[t].trusted for t in np.arange(20.0, 38.0))
    assert all(poses[t].trusted for t in np.arange(41.0, 80.0))


def test_a_converged_filter_runs_icp_on_its_own_patterns_only_with_the_same_result(
        flat, search_walk, monkeypatch):
    """Once the cloud is converged (no pseudo-observation particles are drawn) eq. (2)
    reads only the entries the particles are associated with: the filter compares the
    walk with those patterns alone, and its poses are exactly those of comparing with
    every pattern (Algorithm 1)."""
    from firenav_plugins.constraints.search_pattern_icp import comparison as cmp
    params = {"particles": 300, "start": pose_start(*search_walk.truth_xy[0], 0.0), "seed": 4}
    icp = [(SearchPatternIcpConstraint, {"sigma": 0.3, "resample_above_m2": 3.0})]
    candidates = []
    original = cmp.icp_batch

    def counting(src, patterns, pattern_of, *a, **k):
        candidates.append(len(pattern_of))
        return original(src, patterns, pattern_of, *a, **k)

    monkeypatch.setattr(cmp, "icp_batch", counting)
    rec, _ = run(flat, search_walk, params, icp)
    restricted = list(candidates)
    full_compare = cmp.PatternComparison.compare
    monkeypatch.setattr(cmp.PatternComparison, "compare",
                        lambda self, odo, patterns=None: full_compare(self, odo))
    candidates.clear()
    rec_full, _ = run(flat, search_walk, params, icp)
    a, b = rec.on("pose"), rec_full.on("pose")
    assert len(a) == len(b) and len(restricted) >= len(candidates) > 50
    np.testing.assert_array_equal([p.position for p in a], [p.position for p in b])
    assert [p.trusted for p in a] == [p.trusted for p in b]
    # the full comparison scores every pattern under four rotations at every comparison
    assert len(set(candidates)) == 1
    assert sum(restricted) < 0.5 * sum(candidates)


class RefuteHalf(ParticleConstraint):
    """Between t1 and t2 the plan refutes the half of the cloud east of its weighted mean
    (a factor 0.05, like a wall that may be wrong) at every update."""

    name = "refute_half"

    def __init__(self, params, ctx, t1=20.0, t2=40.0):
        super().__init__(params, ctx)
        self.t1, self.t2 = t1, t2

    def log_likelihood(self, step):
        if not self.t1 <= step.t < self.t2:
            return None
        p = step.particles
        return np.where(p.xy[:, 0] > p.weights @ p.xy[:, 0], math.log(0.05), 0.0)


def run_refute_half(flat, trust: dict, n: int):
    """The filter's recorder after ``n`` s walking east at 0.25 m/s from (2, 2) m with
    :class:`RefuteHalf` between 20 and 40 s and these ``trust`` parameters."""
    params = {"start": pose_start(2.0, 2.0), "motion": {"position_noise": 0.02},
              "trust": trust}
    pf, rec, _ = make_component(ParticleFilterEstimator, params, building=flat)
    pf.constraints.append(make_component(RefuteHalf, {}, building=flat, cid="refute")[0])
    pf.start()
    for msg in straight_walk(n, step_m=0.25):
        pf.handle("odo", msg)
    return rec


@pytest.mark.parametrize("plan_evidence", [None, 0.05])
def test_a_plan_that_keeps_refuting_part_of_the_cloud_is_a_contradiction(flat, plan_evidence):
    """Issue 15: a motion the plan keeps contradicting a part at a time (about half the
    weight per update) never takes the smoothed contradiction level below its floor; the
    product of the retained shares over the last 3 m does: map_error with the place and
    untrusted while it lasts, trusted again once the plan agrees over 3 m."""
    rec = run_refute_half(flat, {"plan_evidence": plan_evidence, "plan_window": 3.0}, 60)
    diags = [(d.t, d.code, d.level, d.active) for d in rec.on("diagnostics")]
    trusted = {p.t: p.trusted for p in rec.on("pose")}
    if plan_evidence is None:       # today's monitors: no map_error, trusted while refuted
        assert diags == [] and trusted[19.0] and trusted[24.0]
        return
    (start, start_code, level, active), (end, end_code, _, cleared) = diags
    assert start_code == end_code == "map_error" and level == "warning" and active
    assert not cleared
    assert 20.0 < start <= 26.0 and 40.0 < end <= 40.0 + 3.0 / 0.25 + 1
    assert "contradicts the plan near (" in rec.on("diagnostics")[0].text
    assert trusted[19.0] and not any(trusted[t] for t in trusted if start <= t < end)


def test_a_pose_the_plan_contradicted_needs_evidence_and_its_covariance_grows(flat):
    """Issue 15: a cloud the plan contradicted may have settled in a look-alike room where
    the walls no longer object; with ``trust.refuted_evidence`` 5 m it stays untrusted for
    5 m walked (20 s at 0.25 m/s) after the plan-evidence episode ends, and while untrusted
    its published covariance grows by 0.1 m of sigma per metre walked since the last
    trusted pose (``trust.untrusted_growth``)."""
    rec = run_refute_half(flat, {"plan_evidence": 0.05, "plan_window": 3.0,
                                 "refuted_evidence": 5.0, "untrusted_growth": 0.1}, 90)
    (start, *_), (end, *_) = [(d.t, d.code) for d in rec.on("diagnostics")]
    poses = {p.t: p for p in rec.on("pose")}
    last_trusted = max(t for t, p in poses.items() if p.trusted and t < start)
    # the map_error episode has ended, the evidence has not been walked yet
    assert not any(poses[t].trusted for t in poses if start <= t < end + 5.0 / 0.25 - 1)
    assert all(poses[t].trusted for t in poses if t >= end + 5.0 / 0.25 + 1)
    for t in (end, end + 10.0):
        sigma = 0.1 * 0.25 * (t - last_trusted)
        assert poses[t].cov[0, 0] >= sigma ** 2 and poses[t].cov[1, 1] >= sigma ** 2
        assert poses[t].protection_radius >= sigma * K99
    trusted_after = min(t for t in poses if t > end and poses[t].trusted)
    assert poses[trusted_after].cov[0, 0] < 0.5       # trusted again: the cloud's own


def test_spread_scale_widens_the_published_cloud_not_the_estimate(flat):
    """``trust.spread_scale`` 2: the same poses, the horizontal covariance of the cloud four
    times (the kernel added after it), heading variance unchanged."""
    def poses(scale):
        params = {"start": pose_start(2.0, 2.0), "seed": 3,
                  "trust": {"spread_scale": scale, "kernel": 0.5}}
        pf, rec, _ = make_component(ParticleFilterEstimator, params, building=flat)
        pf.start()
        for msg in straight_walk(40):
            pf.handle("odo", msg)
        return rec.on("pose")
    one, two = poses(1.0), poses(2.0)
    np.testing.assert_array_equal([p.position for p in one], [p.position for p in two])
    for a, b in zip(one[5:], two[5:]):
        assert b.cov[0, 0] - 0.25 == pytest.approx(4 * (a.cov[0, 0] - 0.25))
        assert b.cov[0, 1] == pytest.approx(4 * a.cov[0, 1])
        assert b.cov[3, 3] == pytest.approx(a.cov[3, 3])
        assert b.protection_radius > a.protection_radius


def _two_alike_storeys():
    """Two identical storeys (one room each), a stair at the far end of the room."""
    return two_storeys("alike", (0, 0, 20, 8), [(16, 6), (19, 6)])


class LookAlikeStorey(ParticleConstraint):
    """A search-pattern match that cannot tell the storeys apart: it replaces a tenth of the
    cloud by copies on floor 1 at the same places and finds floor 1 slightly likelier."""

    name = "look_alike_storey"

    def log_likelihood(self, step):
        return np.where(step.particles.floor == 1, 0.3, 0.0)

    def replacements(self, step):
        p = step.particles
        k = len(p) // 10
        return Particles.create(p.xy[:k].copy(), p.yaw[:k].copy(), floor=np.ones(k, int))


@pytest.mark.parametrize("height_factor", [1.0, 0.05])
def test_the_ins_height_keeps_the_cloud_on_its_storey(height_factor):
    """Walking the ground floor (the INS's height flat), look-alike matches on the storey
    above win the cloud unless the particles' heights are checked against the INS's."""
    b = _two_alike_storeys()
    pf, rec, _ = make_component(ParticleFilterEstimator, {
        "start": pose_start(2.0, 4.0), "particles": 200, "motion": {"position_noise": 0.02},
        "injection": {"weight": "uniform"}, "stairs": {"height_factor": height_factor}},
        building=b)
    look, _, _ = make_component(LookAlikeStorey, {}, building=b, cid="look")
    pf.constraints.append(look)
    for msg in straight_walk(30, step_m=0.3):
        pf.handle("odo", msg)
    floors = [p.floor for p in rec.on("pose")]
    if height_factor < 1:
        assert floors == [0] * len(floors)
    else:
        assert floors[-1] == 1      # the failure the check removes


@pytest.mark.parametrize("height_factor, trusted_at_end", [(1.0, True), (0.05, False)])
def test_a_pose_whose_floor_the_ins_height_refutes_is_not_trusted(height_factor, trusted_at_end):
    """The INS climbs a storey away from any stair (the cloud is off where it climbed):
    every particle stays on the ground floor, a tight cloud, yet the INS's height says the
    floor above. With the check the floor is in doubt and the pose not trusted."""
    b = _two_alike_storeys()
    pf, rec, _ = make_component(ParticleFilterEstimator, {
        "start": pose_start(2.0, 4.0), "particles": 200, "motion": {"position_noise": 0.02},
        "stairs": {"height_factor": height_factor}}, building=b)
    pos = np.zeros(3)
    for k in range(1, 31):
        delta = np.array([0.3, 0.0, 0.3 if 5 <= k < 15 else 0.0])
        pos = pos + delta
        pf.handle("odo", Odometry(t=float(k), agent="ff1", t_start=k - 1.0, delta=delta,
                                  dheading=0.0, cov=np.eye(4) * 1e-4, position=pos.copy(),
                                  heading=0.0))
    poses = rec.on("pose")
    assert poses[0].trusted
    assert all(p.floor == 0 for p in poses)
    assert poses[-1].trusted is trusted_at_end
