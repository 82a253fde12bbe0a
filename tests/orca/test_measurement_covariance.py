"""What a correction knows of the position, fused into the dead-reckoning covariance.

Analytic cases of the Joseph-form update (:mod:`...dead_reckoning.fusion`), the walls'
free-space measurement of the ``orca`` constraint on a hand-drawn corridor, the
estimator fusing a correction's covariance (and not a jump's), and issue 15's ORCA
integrity failure on the simulator: the map-matched covariance never shrank, so the
track was trusted no more often than INS alone although 2-3 times closer.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from firenav_framework.capabilities.odometry_correction import UNKNOWN_VARIANCE, StepCorrection
from firenav_framework.evaluation.runs import evaluate
from firenav_plugins.constraints.orca.free_space import free_space_covariance
from firenav_plugins.constraints.segment_hits import SegmentHits
from firenav_plugins.estimators.dead_reckoning.fusion import fuse_position
from tests.orca.test_dead_reckoning import POSE, ins_steps, run
from tests.orca.walker import building

X_ONLY = np.diag([1.0, UNKNOWN_VARIANCE])


def test_independent_measurements_shrink_as_a_kalman_filter():
    prior = np.diag([4.0, 4.0, 0.0, 0.01])
    once = fuse_position(prior, X_ONLY)
    assert once[0, 0] == pytest.approx(4.0 * 1.0 / 5.0)          # P R / (P + R)
    assert once[1, 1] == pytest.approx(4.0, rel=1e-5)            # unmeasured axis untouched
    twice = fuse_position(once, X_ONLY)
    assert twice[0, 0] == pytest.approx(4.0 / 9.0)               # two looks: P / (1 + 2 P / R)


def test_repeated_evidence_brings_the_variance_down_to_it_and_no_further():
    prior = np.diag([4.0, 4.0, 0.0, 0.01])
    once = fuse_position(prior, X_ONLY, independent=False)
    assert once[0, 0] == pytest.approx(1.0)
    np.testing.assert_allclose(fuse_position(once, X_ONLY, independent=False), once)
    tight = np.diag([0.25, 4.0, 0.0, 0.01])
    np.testing.assert_allclose(fuse_position(tight, X_ONLY, independent=False), tight)


def test_a_position_fix_also_narrows_a_correlated_heading():
    # a heading error of sigma 0.1 rad 10 m along x moves y by 10 * error: the y and
    # heading states are fully correlated; knowing y to 0.1 m knows the heading too
    j = np.array([0.0, 10.0, 0.0, 1.0])
    prior = 0.01 * np.outer(j, j) + np.diag([1e-4, 1e-4, 1e-4, 1e-6])
    post = fuse_position(prior, np.diag([UNKNOWN_VARIANCE, 0.01]))
    assert post[1, 1] == pytest.approx(1.0 * 0.01 / 1.01, rel=1e-3)
    assert post[3, 3] < 0.02 * prior[3, 3]
    np.testing.assert_allclose(post, post.T)
    assert np.all(np.linalg.eigvalsh(post) > 0)


CORRIDOR = [[[0.0, 0.0], [30.0, 0.0]], [[0.0, 3.0], [30.0, 3.0]],
            [[0.0, 0.0], [0.0, 3.0]]]


def test_the_walls_around_a_corridor_walk_bound_it_across_not_along():
    walls = SegmentHits(building(CORRIDOR).floors[0].wall_index)
    cov = free_space_covariance(walls, np.array([5.0, 0.25]), 0.0, 10.0)
    # across: 0.25 m to one wall, 2.75 m to the other, uniform: (a^3 + b^3) / 3 (a + b)
    assert cov[1, 1] == pytest.approx((0.25 ** 3 + 2.75 ** 3) / 9.0)
    assert cov[0, 0] == UNKNOWN_VARIANCE          # open beyond 10 m ahead
    assert cov[0, 1] == pytest.approx(0.0, abs=1e-9)
    near_end = free_space_covariance(walls, np.array([2.0, 1.5]), math.pi, 10.0)
    assert near_end[0, 0] == UNKNOWN_VARIANCE     # the corridor is open 28 m behind
    assert free_space_covariance(SegmentHits(building([[[0.0, -20.0], [0.0, 20.0]]])
                                             .floors[0].wall_index), np.array([1.0, 0.0]), 0.0, 10.0) is None


class _Fix:
    """A constraint that knows y to ``sigma`` [m] at every step (optionally a jump)."""

    def __init__(self, sigma: float, jump: bool = False):
        self.cov, self.jump = np.diag([UNKNOWN_VARIANCE, sigma ** 2]), jump

    def correct(self, step):
        return StepCorrection(position=step.proposed.copy(), cov=self.cov, jump=self.jump,
                              independent=False)


def test_dead_reckoning_fuses_what_a_correction_knows_but_not_a_jump():
    path = np.column_stack([np.arange(31.0), np.zeros(31)])
    alone = run({**POSE}, ins_steps(path))[0].on("pose")
    held, counts = run({**POSE}, ins_steps(path), constraints=[_Fix(0.2)])
    held = held.on("pose")
    assert counts["position_updates"] == 30
    assert all(p.cov[1, 1] <= 0.04 + 1e-9 for p in held)
    assert alone[-1].cov[1, 1] > 0.5
    assert held[-1].cov[0, 0] == pytest.approx(alone[-1].cov[0, 0], rel=0.05)
    assert held[-1].protection_radius < alone[-1].protection_radius
    jumped = run({**POSE}, ins_steps(path), constraints=[_Fix(0.2, jump=True)])
    assert "position_updates" not in jumped[1]


def test_map_matched_track_is_trusted_where_the_map_holds_it(repo):
    """Issue 15: the ORCA pipeline's covariance was that of INS alone, widened by jumps,
    so it was trusted as rarely as INS alone (0.18 of the poses on these runs) though
    2-3 times closer. With the walls' and the ranges' measurement covariances it must be
    trusted far more often, never while more than 3 m off, and its 95 % ellipse must
    still hold the truth (simulator truth, tuning seeds)."""
    kw = dict(scenario="orca_test3", seeds=[100, 101], truth_mode="dense")
    ours = evaluate(repo / "pipelines" / "orca-map-matching.yaml", **kw)
    ins = evaluate(repo / "pipelines" / "ins-baseline.yaml", **kw)
    assert ours.overall.trusted_fraction > 2 * ins.overall.trusted_fraction
    assert ours.overall.ellipse95_containment >= 0.9
    for r in ours.runs:
        (m,) = r.metrics.values()
        assert m.trusted_off_fraction <= 0.02
        assert m.protection_containment >= 0.95
