"""Plain batch BLUE of an assembled Kirchhoff system (eqs. 4-5), the reference solver.

:func:`batch_blue` solves one assembled system with one sparse factorisation.
:class:`BatchBlue` has the interface of :class:`~.incremental.IncrementalBlue` but
re-assembles and refactorises the whole network whenever it is asked after a change:
the "recompute everything" scheme the paper's incremental operations avoid (§IV-A). It
serves as the reference in tests and benchmarks, and for one-off batch problems.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla


class SingularNetworkError(ValueError):
    """The Kirchhoff matrix is singular: some node has no path of linear edges to an anchor."""


@dataclass
class KirchhoffSystem:
    """An assembled ``L x = b`` (eq. 4) over the non-anchor nodes ``nodes`` (ids), in order."""

    L: sp.csc_matrix
    b: np.ndarray
    nodes: np.ndarray
    dim: int


def factorize(L: sp.spmatrix) -> spla.SuperLU:
    """Sparse LU of a symmetric positive definite Kirchhoff matrix (minimum-degree
    ordering on L + L^T, diagonal pivots), with a clear error when it is singular."""
    try:
        return spla.splu(sp.csc_matrix(L), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                         options={"SymmetricMode": True})
    except RuntimeError as exc:  # SuperLU: "Factor is exactly singular"
        raise SingularNetworkError(
            "the Kirchhoff matrix is singular: a node is not tied to an anchor through "
            f"relative-position edges ({exc})") from None


def block_ordering(L: sp.spmatrix, block: int = 1) -> np.ndarray:
    """A fill-reducing elimination order of ``L``'s dimensions: minimum degree (SuperLU's,
    on ``A + A^T``) on the graph of its ``block`` x ``block`` blocks, one vertex per node,
    each node's dimensions kept together in their order.

    The ordering depends on the sparsity pattern only, so it is computed on a surrogate
    with that block pattern (the pattern's graph Laplacian plus the identity, symmetric
    positive definite): for ``block`` 1 exactly the order of factorising ``L`` itself,
    for the 3-dimensional nodes of a GEN about a ninth of its entries and a small fraction
    of a factorisation of ``L``.
    """
    n = L.shape[0]
    if n % block:
        raise ValueError(f"{n} dimensions are not whole blocks of {block}")
    nb = n // block
    coo = sp.coo_matrix(L)
    r, c = coo.row // block, coo.col // block
    off = r != c
    pattern = sp.csr_matrix((np.ones(int(off.sum())), (r[off], c[off])), shape=(nb, nb))
    pattern.sum_duplicates()
    pattern.data[:] = -1.0
    degree = -np.asarray(pattern.sum(axis=1)).ravel()
    surrogate = (pattern + sp.diags(degree + 1.0)).tocsc()
    nodes = np.argsort(factorize(surrogate).perm_c)
    return (nodes[:, None] * block + np.arange(block)).ravel()


class TrailingFactor:
    """A sparse LU of ``L`` with chosen dimensions eliminated last, and their exact joint
    covariance read off the factor's trailing block instead of by solves.

    With the dimensions ``last`` ordered after all others, the trailing blocks of the
    factors multiply to the Schur complement of the rest onto them,
    ``S = L_ll - L_lr L_rr^-1 L_rl``, whose inverse is their covariance (eq. 5):
    ``Sigma_ll = S^-1``. Getting ``Sigma_ll`` by unit right-hand sides instead costs one
    triangular solve pair per dimension (most of a refactorisation's time on a graph of
    thousands of nodes). The ordering is the minimum-degree one of ``L``'s ``block`` x
    ``block`` node blocks (:func:`block_ordering`) with ``last`` moved to the end;
    :meth:`solve` works in ``L``'s own ordering.
    """

    def __init__(self, L: sp.spmatrix, last: np.ndarray, block: int = 1) -> None:
        L = sp.csc_matrix(L)
        n = L.shape[0]
        last = np.asarray(last, np.int64)
        elim = block_ordering(L, block)
        tail = np.zeros(n, bool)
        tail[last] = True
        self.order = np.concatenate([elim[~tail[elim]], last])
        self.where = np.empty(n, np.int64)
        self.where[self.order] = np.arange(n)
        try:
            self._lu = spla.splu(L[self.order][:, self.order].tocsc(), permc_spec="NATURAL",
                                 diag_pivot_thresh=0.0, options={"SymmetricMode": True})
        except RuntimeError as exc:
            raise SingularNetworkError(f"the Kirchhoff matrix is singular ({exc})") from None
        k = len(last)
        schur = (self._lu.L[n - k:, n - k:] @ self._lu.U[n - k:, n - k:]).toarray()
        #: Schur complement onto ``last`` (their information) and its inverse (covariance)
        self.schur = 0.5 * (schur + schur.T)
        cov = np.linalg.inv(self.schur) if k else np.zeros((0, 0))
        self.covariance = 0.5 * (cov + cov.T)

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """``L^-1 rhs`` in ``L``'s ordering."""
        return self._lu.solve(np.asarray(rhs, float)[self.order])[self.where]

    def columns(self, dims: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """``Sigma[rows, dims]`` (eq. 5) by unit right-hand sides, in ``L``'s ordering."""
        rhs = np.zeros((len(self.order), len(dims)))
        rhs[self.where[dims], np.arange(len(dims))] = 1.0
        return self._lu.solve(rhs)[self.where[rows]]


def covariance_columns(lu: spla.SuperLU, n_dims: int, blocks: np.ndarray, d: int) -> np.ndarray:
    """Columns ``Sigma[:, dims of blocks]`` (eq. 5) by solving with unit right-hand sides."""
    dims = (np.asarray(blocks)[:, None] * d + np.arange(d)).ravel()
    rhs = np.zeros((n_dims, len(dims)))
    rhs[dims, np.arange(len(dims))] = 1.0
    return lu.solve(rhs)


def batch_blue(system: KirchhoffSystem, cov_nodes: Sequence[int] = ()
               ) -> tuple[np.ndarray, dict[int, np.ndarray]]:
    """Batch BLUE of an assembled system: estimates (n, d) (eq. 4) and the covariance
    blocks (eq. 5) of ``cov_nodes``, by one sparse factorisation (no dense inverse)."""
    d = system.dim
    if len(system.nodes) == 0:
        return np.zeros((0, d)), {}
    lu = factorize(system.L)
    x = lu.solve(system.b).reshape(-1, d)
    covs: dict[int, np.ndarray] = {}
    if len(cov_nodes):
        where = {int(n): k for k, n in enumerate(system.nodes)}
        blocks = np.array([where[int(n)] for n in cov_nodes])
        cols = covariance_columns(lu, len(system.b), blocks, d)
        for k, (n, blk) in enumerate(zip(cov_nodes, blocks)):
            covs[int(n)] = cols[blk * d:(blk + 1) * d, k * d:(k + 1) * d]
    return x, covs


class BatchBlue:
    """Solver with the incremental solver's interface that recomputes everything."""

    def __init__(self, dim: int, assemble: Callable[[], KirchhoffSystem]) -> None:
        self.d = dim
        self._assemble = assemble
        self._dirty = True
        self._lu: spla.SuperLU | None = None
        self._x = np.zeros((0, dim))
        self._where = np.zeros(0, np.int64)
        self.rebuilds = 0
        self.activated = 0
        self.max_active_dims = self.start_dims = 0

    def _solution(self) -> None:
        if not self._dirty:
            return
        system = self._assemble()      # flushes pending edges, which may mark us dirty
        self._dirty = False
        n = int(system.nodes.max(initial=-1)) + 1
        self._where = np.full(n, -1, np.int64)
        self._where[system.nodes] = np.arange(len(system.nodes))
        if len(system.nodes):
            self._lu = factorize(system.L)
            self._x = self._lu.solve(system.b).reshape(-1, self.d)
        else:
            self._lu, self._x = None, np.zeros((0, self.d))
        self.rebuilds += 1

    def _blocks(self, nodes: Sequence[int]) -> np.ndarray:
        self._solution()
        return self._where[np.asarray(nodes, np.int64)]

    # -- the solver interface used by the network -------------------------------------------
    def border(self, *args, **kw) -> None:
        self._dirty = True

    def update(self, *args, **kw) -> None:
        self._dirty = True

    def hide(self, node: int) -> None:
        self._dirty = True

    def rebuild(self, L, b, nodes, hot=()) -> None:
        self._dirty = True

    def needs_rebuild(self) -> bool:
        return False

    def recent_nodes(self, count: int) -> list[int]:
        return []

    def active_mask(self, n: int) -> np.ndarray:
        return np.zeros(n, bool)

    def active_estimates(self, nodes: np.ndarray) -> np.ndarray:
        return np.zeros((len(nodes), self.d))

    def estimate(self, nodes: Sequence[int]) -> np.ndarray:
        blocks = self._blocks(nodes)        # first: it may re-solve and replace self._x
        return self._x[blocks]

    def covariance(self, nodes: Sequence[int]) -> np.ndarray:
        blocks = self._blocks(nodes)
        cols = covariance_columns(self._lu, self._x.size, blocks, self.d)
        dims = (blocks[:, None] * self.d + np.arange(self.d)).ravel()
        return cols[dims]

    def marginal_covariances(self, nodes: Sequence[int]) -> np.ndarray:
        k, d = len(nodes), self.d
        full = self.covariance(nodes).reshape(k, d, k, d)
        return full[np.arange(k), :, np.arange(k), :]

    def full_estimate(self, n: int) -> np.ndarray:
        self._solution()
        out = np.full((n, self.d), np.nan)
        m = min(n, len(self._where))
        ok = np.flatnonzero(self._where[:m] >= 0)
        out[ok] = self._x[self._where[ok]]
        return out
