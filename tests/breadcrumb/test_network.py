"""The GEN (§IV) against an independent dense BLUE (eqs. 2-5), marginalisation (eq. 17),
range linearisation (eqs. 18-21) and the scaling laws of the paper's table (§IV-F)."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import least_squares

from firenav_plugins.estimators.breadcrumb_gen.network import (
    GeneralizedElectricalNetwork, SingularNetworkError, batch_blue)

from tests.breadcrumb.dense_blue import DenseGraph

TOL = 1e-9


def random_cov(rng: np.random.Generator, d: int = 3, scale: float = 0.3) -> np.ndarray:
    a = rng.normal(size=(d, d)) * scale
    return a @ a.T + 0.05 * np.eye(d)


def assert_matches_dense(gen: GeneralizedElectricalNetwork, dense: DenseGraph) -> None:
    est, sigma, col = dense.solve()
    d = dense.dim
    for key, k in col.items():
        np.testing.assert_allclose(gen.estimate(key), est[key], atol=TOL, rtol=0)
        np.testing.assert_allclose(gen.covariance(key), sigma[k * d:(k + 1) * d, k * d:(k + 1) * d],
                                   atol=TOL, rtol=0)
    keys = list(col)[:4]
    idx = np.concatenate([np.arange(col[k] * d, (col[k] + 1) * d) for k in keys])
    np.testing.assert_allclose(gen.joint_covariance(keys), sigma[np.ix_(idx, idx)], atol=TOL)
    bulk = gen.estimates()
    for key in col:
        np.testing.assert_allclose(bulk[key], est[key], atol=TOL, rtol=0)


def build_random(seed: int, n: int, max_active_dims: int, extra: int = 2, anchors: int = 1,
                 **options):
    """A random graph with loops, built node by node, checked against the dense BLUE
    (``options``: more arguments of the network)."""
    rng = np.random.default_rng(seed)
    gen = GeneralizedElectricalNetwork(3, max_active_dims=max_active_dims, hot_nodes=4,
                                       **options)
    dense = DenseGraph(3)
    names = []
    for a in range(anchors):
        pos = rng.normal(size=3) * 5
        gen.add_anchor(f"a{a}", pos)
        dense.anchors[f"a{a}"] = pos
        names.append(f"a{a}")
    for k in range(n):
        key = f"n{k}"
        gen.add_node(key)
        dense.unknowns.append(key)
        parent = names[rng.integers(len(names))]
        z, cov = rng.normal(size=3), random_cov(rng)
        gen.add_relative_position(key, parent, z, cov)
        dense.relative(key, parent, z, cov)
        for _ in range(rng.integers(0, extra + 1)):
            other = names[rng.integers(len(names))]
            z, cov = rng.normal(size=3), random_cov(rng)
            gen.add_relative_position(other, key, z, cov)   # either direction
            dense.relative(other, key, z, cov)
        names.append(key)
        yield gen, dense


@pytest.mark.parametrize("max_active_dims", [10 ** 6, 24])
def test_linear_graph_equals_dense_blue_after_every_update(max_active_dims):
    """Eqs. 4-5 to 1e-9 after every AddNode/AddMeasurement, with and without the
    refactorisations and activations that a small active set forces."""
    for gen, dense in build_random(1, 30, max_active_dims):
        assert_matches_dense(gen, dense)
    if max_active_dims == 24:
        assert gen.solver.rebuilds > 5 and gen.solver.activated > 10


def test_two_anchors_fold_into_b():
    """Edges touching anchors (eq. 12), including a node between two anchors."""
    for gen, dense in build_random(2, 15, 30, anchors=3):
        pass
    assert_matches_dense(gen, dense)
    system = gen.assemble()
    x, covs = batch_blue(system, system.nodes)
    est, _, _ = dense.solve()
    for k, nid in enumerate(system.nodes):
        np.testing.assert_allclose(x[k], est[gen.key_of(nid)], atol=TOL)


def test_batch_measurements_equal_sequential():
    rng = np.random.default_rng(3)
    seq = GeneralizedElectricalNetwork(2)
    bat = GeneralizedElectricalNetwork(2)
    for g in (seq, bat):
        g.add_anchor("base", [0.0, 0.0])
        for k in range(5):
            g.add_node(k)
    edges = [(k, "base" if k == 0 else k - 1, rng.normal(size=2), random_cov(rng, 2))
             for k in range(5)]
    loops = [(4, 1, rng.normal(size=2), random_cov(rng, 2)), (3, 0, rng.normal(size=2),
                                                            random_cov(rng, 2))]
    for e in edges + loops:
        seq.add_relative_position(*e)
    for e in edges:
        bat.add_relative_position(*e)
    with bat.batch():
        for e in loops:
            bat.add_relative_position(*e)
    for k in range(5):
        np.testing.assert_allclose(bat.estimate(k), seq.estimate(k), atol=TOL)
        np.testing.assert_allclose(bat.covariance(k), seq.covariance(k), atol=TOL)


def test_delete_node_leaves_the_others_unchanged():
    """DeleteNode (eq. 17): the remaining estimates and covariances do not move (eq. 15),
    the Schur-complemented sparse system gives the same BLUE, and later measurements
    give the BLUE of the full graph (marginalisation is exact for linear edges)."""
    for gen, dense in build_random(4, 20, 10 ** 6):
        pass
    keep = [k for k in dense.unknowns if k not in ("n3", "n7")]
    before = {k: (gen.estimate(k), gen.covariance(k)) for k in keep}
    gen.delete_node("n3")
    gen.delete_node("n7")
    assert "n3" not in gen and "n7" not in gen
    for k in keep:
        np.testing.assert_allclose(gen.estimate(k), before[k][0], atol=TOL)
        np.testing.assert_allclose(gen.covariance(k), before[k][1], atol=TOL)
    system = gen.assemble()                      # marginal edges in L and b
    assert len(system.nodes) == len(keep)
    x, covs = batch_blue(system, system.nodes)
    for k, nid in enumerate(system.nodes):
        key = gen.key_of(nid)
        np.testing.assert_allclose(x[k], before[key][0], atol=TOL)
        np.testing.assert_allclose(covs[nid], before[key][1], atol=TOL)
    rng = np.random.default_rng(5)
    for a, b in (("n2", "n9"), ("n15", "n1"), ("n19", "a0")):
        z, cov = rng.normal(size=3), random_cov(rng)
        gen.add_relative_position(a, b, z, cov)
        dense.relative(a, b, z, cov)
    gen.rebuild()                                # the marginal edges now in the factor
    gen.add_relative_position("n4", "n8", np.ones(3), np.eye(3))
    dense.relative("n4", "n8", np.ones(3), np.eye(3))
    est, sigma, col = dense.solve()
    for k in keep:
        np.testing.assert_allclose(gen.estimate(k), est[k], atol=TOL)
        i = col[k] * 3
        np.testing.assert_allclose(gen.covariance(k), sigma[i:i + 3, i:i + 3], atol=TOL)


def test_sliding_window_of_states_is_exact_for_linear_edges():
    """The extended graph (§IV-E): a firefighter's old states are deleted as new ones
    arrive; breadcrumbs keep the BLUE of the full graph."""
    rng = np.random.default_rng(6)
    gen = GeneralizedElectricalNetwork(2, max_active_dims=40, hot_nodes=3)
    dense = DenseGraph(2)
    gen.add_anchor("base", [0.0, 0.0])
    dense.anchors["base"] = np.zeros(2)
    prev = "base"
    for k in range(60):
        s = f"s{k}"
        gen.add_node(s)
        dense.unknowns.append(s)
        z, cov = rng.normal(size=2), random_cov(rng, 2, 0.1)
        gen.add_relative_position(s, prev, z, cov)
        dense.relative(s, prev, z, cov)
        if k % 10 == 5:
            bc = f"bc{k}"
            gen.add_node(bc)
            dense.unknowns.append(bc)
            gen.add_relative_position(bc, s, [0.0, 0.0], 0.2 * np.eye(2))
            dense.relative(bc, s, [0.0, 0.0], 0.2 * np.eye(2))
        if k % 7 == 3 and k > 10:                # pass by an old breadcrumb
            bc = f"bc{5 + 10 * rng.integers(0, k // 10)}"
            z = rng.normal(size=2) * 0.3
            gen.add_relative_position(s, bc, z, 0.3 * np.eye(2))
            dense.relative(s, bc, z, 0.3 * np.eye(2))
        if k >= 3:
            gen.delete_node(f"s{k - 3}")         # window of 3 states
        prev = s
    est, sigma, col = dense.solve()
    for key in [k for k in dense.unknowns if k in gen]:
        np.testing.assert_allclose(gen.estimate(key), est[key], atol=TOL)
        i = col[key] * 2
        np.testing.assert_allclose(gen.covariance(key), sigma[i:i + 2, i:i + 2], atol=TOL)


def test_ranges_linearised_at_the_latest_estimate_match_dense():
    """AddMeasurement+ (eqs. 18-19): a range is linearised at the estimates when it
    arrives; with re-linearisation off the result is the dense BLUE of those linear rows."""
    rng = np.random.default_rng(7)
    gen = GeneralizedElectricalNetwork(3, relinearize_sigma=math.inf, max_active_dims=40,
                                       hot_nodes=2)
    dense = DenseGraph(3)
    gen.add_anchor("base", np.zeros(3))
    dense.anchors["base"] = np.zeros(3)
    truth = {"base": np.zeros(3)}
    keys = ["base"]
    for k in range(25):
        key = f"n{k}"
        parent = keys[rng.integers(len(keys))]
        truth[key] = truth[parent] + rng.normal(size=3) * 3
        z, cov = truth[key] - truth[parent] + rng.normal(size=3) * 0.3, 0.09 * np.eye(3)
        gen.add_node(key)
        dense.unknowns.append(key)
        gen.add_relative_position(key, parent, z, cov)
        dense.relative(key, parent, z, cov)
        for other in rng.choice(keys, size=min(3, len(keys)), replace=False):
            r = float(np.linalg.norm(truth[key] - truth[other]) + rng.normal() * 0.1)
            xi, xj = gen.estimate(key), gen.estimate(other)
            gen.add_range(key, other, r, 0.01)
            dense.range_linearised(key, other, r, 0.01, xi, xj, eps=gen.eps)
        keys.append(key)
        assert_matches_dense(gen, dense)


def test_optimize_reaches_the_nonlinear_least_squares_optimum():
    """Re-linearising until nothing moves (eqs. 20-21 rebuilt) solves the non-linear
    problem: compared with scipy's least_squares on the same residuals."""
    rng = np.random.default_rng(8)
    truth = {"base": np.zeros(2), "p": np.array([4.0, 1.0]), "q": np.array([3.0, 5.0]),
             "r": np.array([-1.0, 4.0])}
    gen = GeneralizedElectricalNetwork(2)
    gen.add_anchor("base", truth["base"])
    rel = [("p", "base", 0.5), ("q", "p", 0.5), ("r", "q", 0.5)]
    rngs = [("r", "base", 0.05), ("q", "base", 0.05), ("r", "p", 0.05)]
    meas = []
    for i, j, s in rel:
        z = truth[i] - truth[j] + rng.normal(size=2) * s
        gen.add_node(i)
        gen.add_relative_position(i, j, z, s ** 2 * np.eye(2))
        meas.append(("rel", i, j, z, s))
    for i, j, s in rngs:
        r = float(np.linalg.norm(truth[i] - truth[j]) + rng.normal() * s)
        gen.add_range(i, j, r, s ** 2)
        meas.append(("rng", i, j, r, s))
    gen.optimize()
    names = ["p", "q", "r"]

    def residuals(v):
        x = {"base": truth["base"], **{n: v[2 * k:2 * k + 2] for k, n in enumerate(names)}}
        out = []
        for kind, i, j, z, s in meas:
            if kind == "rel":
                out.extend((x[i] - x[j] - z) / s)
            else:
                out.append((np.linalg.norm(x[i] - x[j]) - z) / s)
        return np.array(out)

    v0 = np.concatenate([gen.estimate(n) for n in names]) + 0.2
    ref = least_squares(residuals, v0, xtol=1e-15, ftol=1e-15, gtol=1e-15).x
    for k, n in enumerate(names):
        np.testing.assert_allclose(gen.estimate(n), ref[2 * k:2 * k + 2], atol=1e-7)


def heading_chain(gen, dense, rng, steps: int, window: int | None = None, fixes=(7, 13)):
    """A walker with heading states: ``h_k = F h_k-1`` (linear edges), steps turned by
    ``psi_k`` (rotated positions), position fixes to the base every so often. With
    re-linearisation off each rotated position is the linear row taken at the heading
    estimate it was added at, which is what the dense reference gets."""
    d = gen.d
    gen.add_anchor("base", np.zeros(d))
    dense.anchors["base"] = np.zeros(d)
    gen.add_node("h0")
    prior = np.diag([0.05 ** 2, 0.01 ** 2, 0.03 ** 2])
    gen.add_linear(["h0"], np.eye(d), prior, np.zeros(d))
    dense.unknowns.append("h0")
    dense.rows.append((("h0",), (np.eye(d),), np.zeros(d), prior))
    gen.add_node("x0")
    gen.add_relative_position("x0", "base", np.zeros(d), 0.01 * np.eye(d))
    dense.unknowns.append("x0")
    dense.relative("x0", "base", np.zeros(d), 0.01 * np.eye(d))
    live = ["h0", "x0"]
    truth = np.zeros(d)
    for k in range(1, steps):
        h, x = f"h{k}", f"x{k}"
        dtheta = math.pi / 2 if k % 10 == 0 else 0.0
        F = np.array([[1.0, 1.0, dtheta], [0, 1, 0], [0, 0, 1]])
        q = np.diag([1e-4, 1e-6, 1e-6])
        gen.add_node(h)
        gen.add_linear([h, f"h{k - 1}"], np.hstack([np.eye(d), -F]), q, np.zeros(d))
        dense.unknowns.append(h)
        dense.rows.append(((h, f"h{k - 1}"), (np.eye(d), -F), np.zeros(d), q))
        step = np.array([math.cos(k / 10), math.sin(k / 10), 0.0]) + rng.normal(size=d) * 0.05
        truth = truth + step
        psi = gen.estimate(h)[0]
        gen.add_node(x)
        cov = 0.02 * np.eye(d)
        gen.add_rotated_position(x, f"x{k - 1}", h, step, cov)
        c, s_ = math.cos(psi), math.sin(psi)
        turned = np.array([c * step[0] - s_ * step[1], s_ * step[0] + c * step[1], step[2]])
        g = np.array([-turned[1], turned[0], 0.0])
        gh = np.zeros((d, d))
        gh[:, 0] = -g
        dense.unknowns.append(x)
        dense.rows.append(((x, f"x{k - 1}", h), (np.eye(d), -np.eye(d), gh), turned - g * psi,
                           cov))
        if k % fixes[0] == 0 or k % fixes[1] == 0:
            z = truth + rng.normal(size=d) * 0.3
            gen.add_relative_position(x, "base", z, 0.09 * np.eye(d))
            dense.relative(x, "base", z, 0.09 * np.eye(d))
        live += [h, x]
        if window is not None and len(live) > 2 * window:
            for old in live[:2]:
                gen.delete_node(old)
            live = live[2:]
        yield gen, dense, live


@pytest.mark.parametrize("max_active_dims", [10 ** 6, 30])
def test_heading_states_equal_dense_blue_after_every_update(max_active_dims):
    """Linear edges and rotated positions (linearised as in eqs. 18-19) give the dense
    BLUE after every update, through bordering, activations and refactorisations."""
    gen = GeneralizedElectricalNetwork(3, relinearize_sigma=math.inf,
                                       max_active_dims=max_active_dims, hot_nodes=3)
    for gen, dense, _ in heading_chain(gen, DenseGraph(3), np.random.default_rng(11), 40):
        assert_matches_dense(gen, dense)
    assert gen.edge_count()["rotated_position"] == 39 and gen.edge_count()["linear"] == 40


def test_sliding_window_with_heading_states_is_exact():
    """Deleting old states and heading states (eq. 17) keeps the BLUE of the full graph
    when nothing is re-linearised."""
    gen = GeneralizedElectricalNetwork(3, relinearize_sigma=math.inf, max_active_dims=60,
                                       hot_nodes=3)
    for gen, dense, live in heading_chain(gen, DenseGraph(3), np.random.default_rng(12), 60,
                                          window=4):
        pass
    est, sigma, col = dense.solve()
    assert len([k for k in dense.unknowns if k in gen]) == 8
    for key in live:
        np.testing.assert_allclose(gen.estimate(key), est[key], atol=TOL)
        i = col[key] * 3
        np.testing.assert_allclose(gen.covariance(key), sigma[i:i + 3, i:i + 3], atol=TOL)


def test_optimize_with_rotated_positions_reaches_the_nonlinear_optimum():
    """A walk whose odometry is turned by an unknown 40 degrees, closed by two fixes:
    re-linearising the rotated positions to convergence solves the non-linear problem
    (scipy's least_squares on the same residuals), whatever the first linearisation."""
    rng = np.random.default_rng(13)
    true_psi = math.radians(40.0)
    steps = [np.array([2.0, 0.0]), np.array([2.0, 0.5]), np.array([0.0, 2.0]),
             np.array([-1.0, 1.5])]
    gen = GeneralizedElectricalNetwork(2)
    gen.add_anchor("base", [0.0, 0.0])
    gen.add_node("h")
    gen.add_linear(["h"], np.eye(2), np.diag([1.0, 1.0]), np.zeros(2))
    gen.add_node("x0")
    gen.add_relative_position("x0", "base", [0.0, 0.0], 0.01 * np.eye(2))
    truth = np.zeros(2)
    meas = []
    c, s_ = math.cos(true_psi), math.sin(true_psi)
    for k, st in enumerate(steps, 1):
        truth = truth + st
        z = np.array([c * st[0] + s_ * st[1], -s_ * st[0] + c * st[1]])  # R(-psi) step
        z = z + rng.normal(size=2) * 0.05
        gen.add_node(f"x{k}")
        gen.add_rotated_position(f"x{k}", f"x{k - 1}", "h", z, 0.0025 * np.eye(2))
        meas.append((k, z))
    fixes = {2: truth_at(steps, 2) + rng.normal(size=2) * 0.1,
             4: truth_at(steps, 4) + rng.normal(size=2) * 0.1}
    for k, z in fixes.items():
        gen.add_relative_position(f"x{k}", "base", z, 0.01 * np.eye(2))
    gen.optimize()
    names = ["h"] + [f"x{k}" for k in range(5)]

    def residuals(v):
        x = {n: v[2 * i:2 * i + 2] for i, n in enumerate(names)}
        out = list(x["h"])                                    # prior (0, 0), unit sigma
        out.extend(x["x0"] / 0.1)
        ch, sh = math.cos(x["h"][0]), math.sin(x["h"][0])
        for k, z in meas:
            turned = np.array([ch * z[0] - sh * z[1], sh * z[0] + ch * z[1]])
            out.extend((x[f"x{k}"] - x[f"x{k - 1}"] - turned) / 0.05)
        for k, z in fixes.items():
            out.extend((x[f"x{k}"] - z) / 0.1)
        return np.array(out)

    v0 = np.concatenate([gen.estimate(n) for n in names]) + 0.05
    ref = least_squares(residuals, v0, xtol=1e-15, ftol=1e-15, gtol=1e-15).x
    for i, n in enumerate(names):
        np.testing.assert_allclose(gen.estimate(n), ref[2 * i:2 * i + 2], atol=1e-7)
    assert abs(gen.estimate("h")[0] - true_psi) < math.radians(5.0)


def truth_at(steps, k):
    return np.sum(steps[:k], axis=0)


def lattice(dim: int, side: int) -> tuple[GeneralizedElectricalNetwork, dict]:
    """A ``side``^dim lattice of unit relative-position edges (P = I), anchored at the
    centre node (the reference o of the paper's table); plain batch solver."""
    gen = GeneralizedElectricalNetwork(2, incremental=False)
    c = side // 2
    idx = np.indices((side,) * dim).reshape(dim, -1).T
    names = {tuple(p): ("o" if all(v == c for v in p) else tuple(p)) for p in idx}
    gen.add_anchor("o", [0.0, 0.0])
    for p, name in names.items():
        if name != "o":
            gen.add_node(name)
    with gen.batch():
        for p, name in names.items():
            for ax in range(dim):
                q = list(p)
                q[ax] += 1
                if q[ax] < side:
                    gen.add_relative_position(names[tuple(q)], name, [0.0, 0.0], np.eye(2))
    return gen, names


def lattice_variance(dim: int, side: int, dists: list[int]) -> np.ndarray:
    gen, names = lattice(dim, side)
    c = side // 2
    system = gen.assemble()
    keys = [names[tuple([c + dd] + [c] * (dim - 1))] for dd in dists]
    _, covs = batch_blue(system, [gen.id_of(k) for k in keys])
    return np.array([covs[gen.id_of(k)][0, 0] for k in keys])


def test_scaling_laws_on_lattices():
    """§IV-F table: the effective resistance to the reference grows linearly with the
    distance in 1D, logarithmically in 2D and stays bounded in 3D."""
    dists = [2, 4, 8, 16]
    one = lattice_variance(1, 41, dists)
    np.testing.assert_allclose(one / np.array(dists), 1.0, rtol=1e-9)   # Sigma = d P exactly
    two = lattice_variance(2, 49, dists)
    steps = np.diff(two)                       # equal increments per doubling: log law
    assert np.all(steps > 0)
    assert steps.max() / steps.min() < 1.5
    assert abs(steps.mean() - math.log(2) / math.pi) < 0.05    # infinite lattice: ln(d)/pi
    three = lattice_variance(3, 17, [1, 2, 4, 7])
    assert three[-1] < 1.5 * three[1]          # bounded, far below the 1D growth
    assert three[-1] < 0.6


def test_nodes_without_a_linear_edge_wait_for_one():
    """A range alone cannot place a node: it waits, then joins exactly when a
    relative-position edge arrives (and its waiting ranges are applied then)."""
    gen = GeneralizedElectricalNetwork(2, relinearize_sigma=math.inf)
    dense = DenseGraph(2)
    gen.add_anchor("base", [0.0, 0.0])
    dense.anchors["base"] = np.zeros(2)
    gen.add_node("a")
    gen.add_relative_position("a", "base", [3.0, 0.0], np.eye(2))
    dense.unknowns.append("a")
    dense.relative("a", "base", [3.0, 0.0], np.eye(2))
    gen.add_node("b")
    gen.add_range("b", "a", 2.0, 0.04)
    gen.add_node("c")
    gen.add_relative_position("c", "b", [0.5, 0.5], 0.1 * np.eye(2))  # b, c still loose
    assert not gen.is_localised("b") and not gen.is_localised("c")
    with pytest.raises(KeyError, match="no estimate yet"):
        gen.estimate("b")
    gen.add_relative_position("b", "base", [3.0, 2.5], 4.0 * np.eye(2))
    assert gen.is_localised("c")
    dense.unknowns += ["b", "c"]
    dense.relative("b", "base", [3.0, 2.5], 4.0 * np.eye(2))
    # the waiting range was linearised when b got its position: at (3, 2.5) vs a at (3, 0)
    dense.range_linearised("b", "a", 2.0, 0.04, [3.0, 2.5], [3.0, 0.0], eps=gen.eps)
    dense.relative("c", "b", [0.5, 0.5], 0.1 * np.eye(2))
    assert_matches_dense(gen, dense)


def test_bad_input_is_refused_with_clear_errors():
    gen = GeneralizedElectricalNetwork(3)
    gen.add_anchor("base", np.zeros(3))
    gen.add_node("a")
    with pytest.raises(ValueError, match="not finite"):
        gen.add_relative_position("a", "base", [np.nan, 0, 0], np.eye(3))
    with pytest.raises(ValueError, match="not positive definite"):
        gen.add_relative_position("a", "base", [1, 0, 0], -np.eye(3))
    with pytest.raises(ValueError, match="shape"):
        gen.add_relative_position("a", "base", [1, 0], np.eye(3))
    with pytest.raises(KeyError, match="unknown node 'zz'"):
        gen.add_range("a", "zz", 1.0, 0.1)
    with pytest.raises(ValueError, match="var > 0"):
        gen.add_range("a", "base", 1.0, 0.0)
    with pytest.raises(ValueError, match="already exists"):
        gen.add_node("a")
    with pytest.raises(ValueError, match="anchor"):
        gen.delete_node("base")
    with pytest.raises(ValueError, match="finite position"):
        gen.add_anchor("b2", [0, np.inf, 0])
    gen.add_node("h")
    with pytest.raises(ValueError, match="J must be"):
        gen.add_linear(["h"], np.eye(2), np.eye(3), np.zeros(3))
    with pytest.raises(ValueError, match="not positive definite"):
        gen.add_linear(["h"], np.eye(3), np.zeros((3, 3)), np.zeros(3))
    with pytest.raises(ValueError, match="not finite"):
        gen.add_linear(["h"], np.eye(3), np.eye(3), [0, np.nan, 0])
    with pytest.raises(ValueError, match="distinct nodes"):
        gen.add_linear(["h", "h"], np.eye(3, 6), np.eye(3), np.zeros(3))
    with pytest.raises(ValueError, match="three different nodes"):
        gen.add_rotated_position("a", "base", "a", [1, 0, 0], np.eye(3))
    gen.add_relative_position("a", "base", [1, 0, 0], np.eye(3))
    gen.delete_node("a")
    with pytest.raises(KeyError, match="deleted"):
        gen.estimate("a")


def test_singular_system_is_reported():
    from firenav_plugins.estimators.breadcrumb_gen.network import KirchhoffSystem
    import scipy.sparse as sp
    system = KirchhoffSystem(sp.csc_matrix((6, 6)), np.zeros(6), np.array([0, 1]), 3)
    with pytest.raises(SingularNetworkError, match="singular"):
        batch_blue(system)


def test_trailing_factor_gives_the_covariance_of_the_dims_eliminated_last():
    """The hot nodes' joint covariance read off the factor's trailing block (a rebuild's
    re-activation without solves) equals the dense inverse; solves are in L's order."""
    from firenav_plugins.estimators.breadcrumb_gen.batch import TrailingFactor
    for gen, _ in build_random(4, 40, 10 ** 6, extra=3):
        pass
    system = gen.assemble()
    dense = np.linalg.inv(system.L.toarray())
    last = np.array([5, 6, 7, 30, 31, 32, 90, 91, 92, 3])
    for block in (1, 3):          # ordered by dimension, and by 3-dimensional node
        tf = TrailingFactor(system.L, last, block=block)
        np.testing.assert_allclose(tf.covariance, dense[np.ix_(last, last)], atol=TOL, rtol=0)
        np.testing.assert_allclose(tf.schur @ tf.covariance, np.eye(len(last)), atol=1e-8)
        np.testing.assert_allclose(tf.solve(system.b), dense @ system.b, atol=TOL, rtol=0)
        assert list(tf.order[-len(last):]) == list(last)


def test_block_ordering_is_minimum_degree_on_the_nodes():
    """The elimination order of a GEN's Kirchhoff matrix by 3-dimensional node keeps each
    node's dimensions together, is SuperLU's own minimum-degree order when taken by
    dimension (block 1), and fills the factor about as little as that order."""
    import scipy.sparse.linalg as spla

    from firenav_plugins.estimators.breadcrumb_gen.batch import block_ordering, factorize
    for gen, _ in build_random(5, 300, 10 ** 6, extra=3):
        pass
    L = gen.assemble().L.tocsc()
    n = L.shape[0]
    np.testing.assert_array_equal(block_ordering(L, 1), np.argsort(factorize(L).perm_c))
    order = block_ordering(L, 3)
    assert sorted(order) == list(range(n))
    np.testing.assert_array_equal(order.reshape(-1, 3) % 3, np.tile([0, 1, 2], (n // 3, 1)))
    np.testing.assert_array_equal(order.reshape(-1, 3)[:, 0] // 3, order.reshape(-1, 3)[:, 2] // 3)

    def fill(perm: np.ndarray) -> int:
        lu = spla.splu(L[perm][:, perm].tocsc(), permc_spec="NATURAL", diag_pivot_thresh=0.0,
                       options={"SymmetricMode": True})
        return lu.L.nnz + lu.U.nnz
    assert fill(order) <= 1.25 * fill(block_ordering(L, 1))
    assert fill(order) < 0.5 * fill(np.arange(n))            # far below no reordering
    with pytest.raises(ValueError, match="whole blocks of 7"):
        block_ordering(L, 7)
