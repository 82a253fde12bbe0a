"""Issue 15: ORCA + UWB confidently wrong on the incident. Two ways the walls held a wrong
position tightly: a refused reset (the INS in another compartment, no way through doors)
kept the track trusted while the walker walked away from it, and one step's free-space
evidence in a wrong room shrank the covariance a jump had just widened back to the
room's size."""
from __future__ import annotations

import math

import numpy as np
import pytest

from firenav_framework.capabilities.odometry_correction import OdometryStep
from firenav_framework import Odometry
from firenav_framework.geometry import Rigid2D
from firenav_framework.testing import make_component
from firenav_plugins.constraints.orca import OrcaConstraint
from firenav_plugins.constraints.orca.free_space import free_space_covariance, inside_probability
from firenav_plugins.constraints.segment_hits import SegmentHits
from tests.orca.walker import Walker, building

WALL = [[[-50.0, 0.0], [50.0, 0.0]]]
#: A closed 4 m x 4 m room, corners (0, 0) and (4, 4).
ROOM = [[[0.0, 0.0], [4.0, 0.0]], [[4.0, 0.0], [4.0, 4.0]], [[4.0, 4.0], [0.0, 4.0]],
        [[0.0, 4.0], [0.0, 0.0]]]


def test_a_refused_reset_widens_is_not_trusted_and_says_where():
    """The INS walks on through a wall with no door: the reset is refused and the walls
    hold the agent. Map and odometry disagree: the poses from then on are not trusted,
    their covariance grows by at least each step not taken, no wall evidence is fused,
    and one diagnostic gives the place (before: trusted, the covariance as small as at
    the start but for the first step the wall held back)."""
    b = building(WALL)
    w = Walker(b, (0.0, 1.0), -math.pi / 2, orca={"reset_from": "ins_speed"})
    for _ in range(6):
        w.step(0.0, -1.0)
    assert w.counts().get("orca_reset_refused", 0) >= 1
    poses = w.rec.on("pose")
    var = [float(np.trace(p.cov[:2, :2])) for p in poses]
    # the first step: the start's 2 x 0.3^2 m^2 and the 0.625 m the wall held it back
    # (dead_reckoning's correction_doubt), still trusted
    assert poses[0].trusted and var[0] < 0.2 + 0.625 ** 2 + 0.01
    # held from the second step on: each adds at least the square of the metre not moved
    assert all(b - a >= 0.9 for a, b in zip(var[1:], var[2:]))
    assert not any(p.trusted for p in poses[2:])
    diags = [d for d in w.constraint_records[0].on("diagnostics")
             if d.code == "orca_held_in_doubt"]
    assert len(diags) == 1 and "(0.0, 0.6)" in diags[0].text


def test_inside_probability_is_the_gaussian_mass_between_the_walls():
    """Analytic: sigma 1 m, walls 1 m either side: 0.6827; 2 m ahead, nothing behind:
    0.4772; zero covariance: certainly inside."""
    axis = np.array([0.0, 1.0])
    assert inside_probability(np.eye(2), axis, 1.0, 1.0) == pytest.approx(0.682689, abs=1e-6)
    assert inside_probability(np.eye(2), axis, 2.0, 0.0) == pytest.approx(0.477250, abs=1e-6)
    assert inside_probability(np.diag([4.0, 0.0]), axis, 0.1, 0.1) == 1.0


def test_the_walls_say_nothing_where_the_covariance_puts_the_walker_beyond_them():
    """In the middle of the 4 m room (2 m to each wall) the walls give the uniform
    variance (8 + 8) / 12 = 4/3 m^2 on both axes while the prior is 1 m (inside with 0.95);
    with a prior of 6 m (after a jump: inside with 0.26) neither axis is measured."""
    walls = SegmentHits(building(ROOM).floors[0].wall_index)
    at = np.array([2.0, 2.0])
    tight = free_space_covariance(walls, at, 0.0, 10.0, np.eye(2), 0.5)
    np.testing.assert_allclose(tight, np.eye(2) * 4.0 / 3.0, atol=1e-9)
    assert free_space_covariance(walls, at, 0.0, 10.0, np.eye(2) * 36.0, 0.5) is None


def test_orca_reports_no_free_space_to_a_widened_estimator():
    """The constraint itself, given the estimator's covariance with the step: a free step
    in the room carries the free-space covariance under a 1 m prior and none under 6 m
    (before, the walls were reported whatever the estimator's covariance)."""
    c, _, _ = make_component(OrcaConstraint, {}, building=building(ROOM))
    c.start()

    def step(sigma: float):
        odo = Odometry(t=1.0, agent="ff1", t_start=0.0, delta=np.array([0.3, 0.0, 0.0]),
                       dheading=0.0, cov=np.eye(4) * 1e-4, position=np.zeros(3), heading=0.0)
        return c.correct(OdometryStep(agent="ff1", t=1.0, dt=1.0, prev=np.array([1.85, 2.0, 0.0]),
                                      proposed=np.array([2.15, 2.0, 0.0]), heading=0.0,
                                      transform=Rigid2D(), ins_position=np.zeros(3),
                                      odometry=odo, cov=np.eye(2) * sigma ** 2))

    fix = step(1.0)
    assert fix is not None and fix.cov is not None
    assert fix.cov[0, 0] == pytest.approx((2.15 ** 3 + 1.85 ** 3) / 12.0)
    assert step(6.0) is None
