"""Resampling schemes and the paper's replacement of removed particles."""
from __future__ import annotations

import numpy as np
import pytest

from firenav_framework.capabilities import Particles
from firenav_plugins.estimators.particle_filter.resampling import (RESAMPLERS, replace_removed,
                                                                   resample_indices)

WEIGHTS = np.array([0.005, 0.3, 0.0, 0.123, 0.25, 0.022, 0.3])


@pytest.mark.parametrize("method", RESAMPLERS)
def test_expected_copies_are_n_times_the_weight(method):
    rng = np.random.default_rng(1)
    n, runs = 50, 4000
    counts = np.zeros(len(WEIGHTS))
    for _ in range(runs):
        counts += np.bincount(resample_indices(WEIGHTS, n, rng, method), minlength=len(WEIGHTS))
    mean = counts / runs
    # the per-run count of particle i has variance at most n w_i (1 - w_i) (multinomial)
    se = np.sqrt(n * WEIGHTS * (1 - WEIGHTS) / runs)
    np.testing.assert_array_less(np.abs(mean - n * WEIGHTS), 5 * se + 1e-12)
    assert mean[2] == 0.0  # a zero-weight particle is never copied


@pytest.mark.parametrize("method", ["systematic", "stratified", "residual"])
def test_low_variance_schemes_stay_within_one_of_the_expected_count(method):
    rng = np.random.default_rng(2)
    for _ in range(200):
        w = rng.dirichlet(np.ones(30) * 0.5)
        c = np.bincount(resample_indices(w, 100, rng, method), minlength=30)
        assert c.sum() == 100
        if method == "systematic":  # systematic: floor(n w) or ceil(n w), exactly
            assert np.all((c >= np.floor(100 * w) - 1e-9) & (c <= np.ceil(100 * w) + 1e-9))
        if method == "residual":
            assert np.all(c >= np.floor(100 * w))


def test_unknown_method_is_a_clear_error():
    with pytest.raises(ValueError, match="unknown resampling method 'best'"):
        resample_indices(WEIGHTS, 10, np.random.default_rng(), "best")


def test_replacing_removed_particles_preserves_the_survivors_distribution():
    rng = np.random.default_rng(3)
    n = 400
    p = Particles.create(rng.normal(size=(n, 2)), rng.uniform(-3, 3, n))
    p.logw = np.log(rng.dirichlet(np.ones(n)))
    removed = rng.random(n) < 0.3
    alive_w = np.exp(p.logw[~removed])
    want_mean = (alive_w @ p.xy[~removed]) / alive_w.sum()
    want_second = (alive_w @ p.xy[~removed] ** 2) / alive_w.sum()
    replaced = replace_removed(p, removed, rng)
    assert replaced == removed.sum()
    w = p.weights
    assert w.sum() == pytest.approx(1.0)
    # a survivor copied k times shares its weight with its copies: same weighted moments
    np.testing.assert_allclose(w @ p.xy, want_mean, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(w @ p.xy ** 2, want_second, rtol=1e-12)
    # every replaced particle is an exact copy of a survivor
    survivors = {tuple(x) for x in p.xy[~removed]}
    assert all(tuple(x) in survivors for x in p.xy[removed])


def test_nothing_to_copy_from_leaves_the_set_alone():
    p = Particles.create(np.zeros((5, 2)), np.zeros(5))
    before = p.copy()
    assert replace_removed(p, np.ones(5, bool), np.random.default_rng()) == 0
    np.testing.assert_array_equal(p.logw, before.logw)


def test_local_weight_is_the_kernel_mean_of_the_neighbours():
    from firenav_plugins.estimators.particle_filter.particles import local_log_weight
    p = Particles.create(np.array([[0.0, 0.0], [0.0, 0.0], [10.0, 0.0]]), np.zeros(3),
                         floor=np.array([0, 0, 0]))
    p.logw = np.log(np.array([0.1, 0.3, 0.6]))
    lw = local_log_weight(p, np.array([[0.0, 0.0], [10.0, 0.0], [50.0, 0.0], [0.0, 0.0]]),
                          np.zeros(4), np.array([0, 0, 0, 1]), 1.0, 0.5)
    assert np.exp(lw[0]) == pytest.approx(0.2)     # mean of its two co-located neighbours
    assert np.exp(lw[1]) == pytest.approx(0.6)
    assert lw[2] == -np.inf and lw[3] == -np.inf     # no support there / on that floor
