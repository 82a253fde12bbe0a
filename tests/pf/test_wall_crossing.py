"""Wall crossing: exactly the particles whose moves cross a wall are removed (§IV-E)."""
from __future__ import annotations

import math

import numpy as np
import pytest
import shapely

from firenav_framework import Odometry
from firenav_framework.building.sketch import PlanSketch
from firenav_framework.testing import make_component
from firenav_plugins.constraints.wall_crossing import WallCrossingConstraint
from firenav_framework.capabilities import ParticleConstraint, Particles, ParticleStep
from firenav_plugins.estimators.particle_filter import ParticleFilterEstimator
from firenav_framework.capabilities import OdometryHistory


@pytest.fixture(scope="module")
def building():
    """Two storeys of two rooms; the upper one has an extra wall across room A."""
    sk = PlanSketch("walls")
    for level in range(2):
        f = sk.floor(3.0 * level, 3.0)
        f.room(f"A{level}", (0, 0, 4, 3)).room(f"B{level}", (4, 0, 8, 3))
        f.door(f"d{level}", (4, 1.5), 1.0, (1, 0))
    sk.floors[1].wall((2, 0), (2, 3))
    sk.floors[0].door("front", (0, 1.5), 1.0, (1, 0))
    sk.entrance("e", (0, 1.5), door="front")
    return sk.build()


def brute_force(building, floor, p0, p1):
    """Independent answer: shapely intersection of each move with the floor's walls."""
    out = np.zeros(len(p0), bool)
    for fl in np.unique(floor):
        sel = floor == fl
        walls = shapely.multilinestrings(building.floors[fl].walls)
        moves = shapely.linestrings(np.stack([p0[sel], p1[sel]], axis=1))
        out[sel] = shapely.intersects(moves, walls)
    return out


def random_step(building, n, rng):
    xy = rng.uniform([-0.5, -0.5], [8.5, 3.5], (n, 2))
    before = Particles.create(xy, rng.uniform(-math.pi, math.pi, n), rng.integers(0, 2, n))
    after = before.copy()
    after.xy = xy + rng.normal(0, 0.8, (n, 2))
    odo = Odometry(t=1.0, t_start=0.5, delta=np.zeros(3), dheading=0.0, cov=np.eye(4),
                   position=np.zeros(3), heading=0.0)
    return ParticleStep(agent="ff1", t=1.0, odometry=odo, before=before, particles=after,
                        history=OdometryHistory(), ins_heading=0.0, walk_offset=0.0, rng=rng,
                        building=building)


@pytest.mark.parametrize("mode, penalty", [("remove", -math.inf), ("downweight", math.log(0.05))])
def test_exactly_the_crossing_moves_are_penalised(building, mode, penalty):
    rng = np.random.default_rng(7)
    step = random_step(building, 5000, rng)
    wc, _, stats = make_component(WallCrossingConstraint, {"mode": mode, "factor": 0.05, "outside": "allow"},
                                  building=building)
    ll = wc.log_likelihood(step)
    want = brute_force(building, step.before.floor, step.before.xy, step.particles.xy)
    assert 500 < want.sum() < 4500                  # both kinds are well represented
    np.testing.assert_array_equal(ll == penalty, want)
    np.testing.assert_array_equal(ll == 0.0, ~want)
    assert stats.counts["under_test"]["wall_crossings"] == want.sum()
    # the upper floor's extra wall at x = 2 (y 0..3) stops every move across it there
    upper = step.before.floor == 1
    through_x2 = ((step.before.xy[:, 0] - 2) * (step.particles.xy[:, 0] - 2) < 0)
    inside = ((step.before.xy[:, 1] > 0) & (step.particles.xy[:, 1] > 0)
              & (step.before.xy[:, 1] < 3) & (step.particles.xy[:, 1] < 3))
    assert (upper & through_x2 & inside).sum() > 50
    assert np.all(ll[upper & through_x2 & inside] == penalty)


def test_leaving_the_building_counts_as_crossing(building):
    rng = np.random.default_rng(8)
    step = random_step(building, 5000, rng)
    wc, _, _ = make_component(WallCrossingConstraint, {}, building=building)     # outside: remove
    crossed = brute_force(building, step.before.floor, step.before.xy, step.particles.xy)
    end = step.particles.xy
    outside = ~shapely.intersects_xy(shapely.box(0, 0, 8, 3), end[:, 0], end[:, 1])
    assert (outside & ~crossed).sum() > 100          # e.g. out through the front door
    np.testing.assert_array_equal(wc.log_likelihood(step) == -math.inf, crossed | outside)


class Probe(ParticleConstraint):
    """Records each step's moves; contributes no information."""

    name = "probe"

    def __init__(self, params, ctx):
        super().__init__(params, ctx)
        self.steps = []

    def log_likelihood(self, step):
        self.steps.append((step.before.copy(), step.particles.copy()))
        return None


def test_filter_keeps_only_particles_whose_moves_did_not_cross(building):
    pf, rec, stats = make_component(ParticleFilterEstimator, {
        "particles": 3000, "start": {"mode": "unknown"}, "resampling": {"below_ess": 0.0}},
        building=building)
    wc, _, _ = make_component(WallCrossingConstraint, {}, building=building, cid="walls")
    probe, _, _ = make_component(Probe, {}, building=building, cid="probe")
    pf.constraints += [wc, probe]
    pos = np.zeros(3)
    for k in range(1, 4):          # three 1.5 m strides east in the INS frame
        delta = np.array([1.5, 0.0, 0.0])
        pos = pos + delta
        pf.handle("odo", Odometry(t=k, agent="ff1", t_start=k - 1.0, delta=delta, dheading=0.0,
                                  cov=np.eye(4) * 1e-4, position=pos, heading=0.0))
        before, after = probe.steps[-1]
        crossed = brute_force(building, before.floor, before.xy, after.xy)
        final = pf.state["ff1"].particles
        allowed = {tuple(x) for x in after.xy[~crossed]}
        assert crossed.any()
        assert all(tuple(x) in allowed for x in final.xy)
    assert stats.counts["under_test"]["replaced_particles"] > 0
    assert len(rec.on("pose")) == 3
