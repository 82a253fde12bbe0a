"""Eq. (1), batched ICP and Algorithm 1 on analytic cases."""
from __future__ import annotations

import math

import numpy as np
import pytest

from firenav_framework.building.search_patterns import extract_search_patterns
from firenav_plugins.constraints.search_pattern_icp.comparison import PatternComparison
from firenav_plugins.constraints.search_pattern_icp.icp import icp_batch
from firenav_plugins.constraints.search_pattern_icp.principal import principal_rotation
from tests.building.test_search_patterns import small_plan

# an L-shaped then U-turning walk along walls: 3 m east, 2 m north, 2 m west
PATTERN = np.array([[0, 0], [1, 0], [2, 0], [3, 0], [3, 1], [3, 2], [2, 2], [1, 2]], float)


def rot(a: float) -> np.ndarray:
    return np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])


def densify(poly: np.ndarray, step: float) -> np.ndarray:
    d = np.hypot(*np.diff(poly, axis=0).T)
    s = np.concatenate([[0], np.cumsum(d)])
    t = np.arange(0, s[-1] + 1e-9, step)
    return np.column_stack([np.interp(t, s, poly[:, 0]), np.interp(t, s, poly[:, 1])])


@pytest.mark.parametrize("a", [0.0, 0.3, -0.7, 2.0])
def test_principal_rotation_aligns_a_rectilinear_walk(a):
    walk = densify(PATTERN, 0.5) @ rot(a).T
    phi = principal_rotation(walk)
    # rotating by phi puts every step on a principal heading: a - phi is a multiple of pi/2
    assert abs(math.remainder(a + phi, math.pi / 2)) < 1e-9
    assert -math.pi / 4 <= phi < math.pi / 4
    # against a building whose axes point at 10 deg
    phi10 = principal_rotation(walk, math.radians(10))
    assert abs(math.remainder(a + phi10 - math.radians(10), math.pi / 2)) < 1e-9


def test_principal_rotation_minimises_the_paper_cost():
    rng = np.random.default_rng(5)
    walk = np.cumsum(rng.normal(size=(40, 2)), axis=0)
    theta = np.arctan2(*np.diff(walk, axis=0).T[::-1])

    def cost(phi):  # eq. (1) with the distance taken modulo 2 pi
        r = np.mod(theta + phi, math.pi / 2)
        return np.minimum(r, math.pi / 2 - r).sum()

    grid = np.linspace(-math.pi / 4, math.pi / 4, 20001)
    best = min(cost(g) for g in grid)
    assert cost(principal_rotation(walk)) <= best + 1e-9


@pytest.mark.parametrize("a, t", [(0.4, (2.0, -1.0)), (-1.2, (-3.5, 4.0)), (math.pi, (0.0, 7.0))])
def test_icp_recovers_a_known_rigid_transform_exactly(a, t):
    """Odometry = the pattern moved by (R, t)^-1: ICP must find (R, t) with zero error."""
    t = np.array(t)
    odo = (densify(PATTERN, 0.25) - t) @ rot(a)      # R^T (p - t), row-wise
    init = np.array([a + 0.2, a - 0.25, a + math.pi / 2])
    rmse, theta, trans, iters = icp_batch(odo, PATTERN[None], np.zeros(3, int), init,
                                          max_iter=500, tol=1e-13)
    for k in range(2):  # the two nearby starts converge to the truth
        assert rmse[k] < 1e-9
        assert abs(math.remainder(theta[k] - a, 2 * math.pi)) < 1e-9
        np.testing.assert_allclose(trans[k], t, atol=1e-9)
    assert rmse[2] > 0.05  # a quarter turn off is a different (worse) local fit


def test_batched_icp_equals_one_call_per_candidate():
    rng = np.random.default_rng(6)
    pats = PATTERN[None] + rng.normal(0, 0.3, (6, 1, 2)) + rng.normal(0, 0.05, (6, 8, 2))
    odo = densify(PATTERN, 0.4) @ rot(0.2).T
    odo = odo + rng.normal(0, 0.05, odo.shape)
    which = np.repeat(np.arange(6), 4)
    init = np.tile(np.arange(4) * math.pi / 2, 6)
    batch = icp_batch(odo, pats, which, init)
    for c in range(len(which)):
        one = icp_batch(odo, pats[which[c]][None], np.zeros(1, int), init[c:c + 1])
        for b, o in zip(batch, one):
            np.testing.assert_allclose(b[c], o[0], rtol=0, atol=0)


def test_icp_refuses_malformed_input():
    with pytest.raises(ValueError, match=r"\(P >= 2, 2\)"):
        icp_batch(np.zeros((1, 2)), PATTERN[None], np.zeros(1, int), np.zeros(1))
    with pytest.raises(ValueError, match="does not exist"):
        icp_batch(np.zeros((5, 2)), PATTERN[None], np.array([3]), np.zeros(1))


@pytest.fixture(scope="module")
def comparison():
    sp = extract_search_patterns(small_plan().build())
    return PatternComparison(sp, length_m=6.0)


@pytest.mark.parametrize("reverse", [False, True])
def test_algorithm1_scores_the_walked_pattern_zero_at_the_right_end(comparison, reverse):
    """An odometry trajectory that *is* sub-pattern k (moved and turned arbitrarily) gets
    E = 0 at pattern k: in column 2 (last node, right-hand) when walked forwards, in
    column 1 (first node, left-hand) when walked backwards (Algorithm 1, steps 7-12)."""
    sub = comparison.sub
    k = 3                                           # (4.5, .5) ... round the side room
    path = sub.points[k][::-1] if reverse else sub.points[k]
    odo = (densify(path, 0.25) - np.array([10.0, -4.0])) @ rot(1.1)   # INS frame
    obs = comparison.compare(odo)
    entry = 2 * k + (0 if reverse else 1)
    assert obs.rmse[entry] < 1e-3
    assert np.isinf(obs.rmse[2 * k + (1 if reverse else 0)]) or obs.rmse[2 * k + (1 if reverse else 0)] > 1e-3
    np.testing.assert_allclose(obs.position[entry], path[-1])
    # Hea: the direction the walk arrives in at its end (for the left-hand entry this is
    # Algorithm 1's Hea(eta, 1); for the right-hand one see right_hand_heading)
    d = path[-1] - path[-2]
    want = math.atan2(d[1], d[0])
    assert obs.heading[entry] == pytest.approx(want)
    # a particle at that node heading the walked way is scored with that entry
    e = comparison.associate(obs, path[-1][None] + 0.1, np.array([want]), np.zeros(1, int))
    assert e[0] == pytest.approx(obs.rmse[entry])


def test_right_hand_heading_conventions():
    sp = extract_search_patterns(small_plan().build())
    arrival = PatternComparison(sp, 6.0)
    paper = PatternComparison(sp, 6.0, right_hand_heading="departure")
    sub = paper.sub
    # left-hand entries are Algorithm 1's Hea(eta, 1) in both
    np.testing.assert_allclose(paper.entry_heading[0::2], sub.first_heading)
    np.testing.assert_allclose(arrival.entry_heading[0::2], sub.first_heading)
    # right-hand: the paper's Hea(eta, 2) is the step after the last node ...
    np.testing.assert_allclose(paper.entry_heading[1::2], sub.last_heading)
    # ... "arrival" the step into it; they differ exactly at the corners of the walk
    d_in = sub.points[:, -1] - sub.points[:, -2]
    np.testing.assert_allclose(arrival.entry_heading[1::2], np.arctan2(d_in[:, 1], d_in[:, 0]))
    corner = np.abs(np.angle(np.exp(1j * (arrival.entry_heading[1::2] - sub.last_heading)))) > 1
    assert 0 < corner.sum() < len(sub)
    with pytest.raises(ValueError, match="right_hand_heading"):
        PatternComparison(sp, 6.0, right_hand_heading="sideways")


def _step_after_walking(path_map: np.ndarray, cloud_at: np.ndarray, spread: float,
                        building, rng) -> "object":
    """A ParticleStep whose INS history walked ``path_map`` (seen rotated by 1 rad in the
    INS frame) and whose 200 particles sit at ``cloud_at`` heading the way the walk ended."""
    from firenav_framework import Odometry
    from firenav_framework.capabilities import Particles, ParticleStep
    from firenav_framework.capabilities import OdometryHistory

    lead_in = path_map[:1] - (path_map[1] - path_map[0])     # walk a metre more than d
    ins = densify(np.vstack([lead_in, path_map]), 0.25) @ rot(-1.0).T
    h = OdometryHistory(100)
    for k, p in enumerate(ins):
        h.append(float(k), np.array([p[0], p[1], 0.0]), 0.0)
    d = ins[-1] - ins[-2]
    ins_heading = math.atan2(d[1], d[0])
    heading_map = ins_heading + 1.0
    n = 200
    p = Particles.create(cloud_at + rng.normal(0, 0.05, (n, 2)), np.full(n, heading_map - ins_heading))
    odo = Odometry(t=float(len(ins)), t_start=len(ins) - 1.0, delta=np.zeros(3), dheading=0.0,
                   cov=np.eye(4), position=np.zeros(3), heading=ins_heading)
    return ParticleStep(agent="ff1", t=float(len(ins)), odometry=odo, before=p.copy(), particles=p,
                        history=h, ins_heading=ins_heading, walk_offset=0.0, rng=rng,
                        building=building, spread_m2=spread)


@pytest.mark.parametrize("gate, spread, resampled", [
    (0.0, 0.1, True),        # the paper: resample after every comparison
    (3.0, 5.0, True),        # not converged yet (or disturbed)
    (3.0, 0.1, False),       # converged: leave it alone
])
def test_pseudo_observation_resampling_gate(gate, spread, resampled):
    from firenav_framework.testing import make_component
    from firenav_plugins.constraints.search_pattern_icp import SearchPatternIcpConstraint

    b = small_plan().build()
    icp, _, stats = make_component(SearchPatternIcpConstraint, {"length_m": 6.0, "resample_above_m2": gate},
                                   building=b)
    icp.start()
    path = icp.comparison.sub.points[3]                # (4.5, .5) ... round the side room
    step = _step_after_walking(path, path[-1], spread, b, np.random.default_rng(9))
    ll = icp.log_likelihood(step)
    assert ll is not None and ll.shape == (200,)
    new = icp.replacements(step)
    assert (new is not None) == resampled
    if resampled:
        assert len(new) == 20                           # q = 10 % of 200
        # drawn from the pseudo-observations: mostly at the walked pattern's end
        assert np.median(np.hypot(*(new.xy - path[-1]).T)) < 1.0


def test_comparison_restricted_to_some_patterns_equals_the_full_one_there(comparison):
    """Each sub-pattern's entries depend on that pattern alone: comparing with a subset
    gives exactly the full comparison's entries of the subset and +inf elsewhere."""
    sub = comparison.sub
    odo = (densify(sub.points[3], 0.25) - np.array([10.0, -4.0])) @ rot(1.1)
    full = comparison.compare(odo)
    some = np.array([1, 3, len(sub) - 1])
    part = comparison.compare(odo, some)
    mine = np.zeros(2 * len(sub), bool)
    mine[2 * some] = mine[2 * some + 1] = True
    np.testing.assert_array_equal(part.rmse[mine], full.rmse[mine])
    assert np.isinf(part.rmse[~mine]).all() and np.isfinite(full.rmse[~mine]).any()
