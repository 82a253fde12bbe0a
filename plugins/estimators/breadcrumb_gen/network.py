"""The relative measurement graph (RMG) as a generalized electrical network (GEN), §IV.

Nodes are the base station and other anchors (known positions, "grounded"), breadcrumbs
(static) and firefighter states (one node per time step in the extended graph, §IV-E).
Edges are measurements; an edge's matrix resistance is its error covariance ``P``.

The network keeps every edge in columnar tables so that the Kirchhoff matrix ``L`` and
the vector ``b`` (eqs. 4, 7, 9; for ranges eqs. 20, 21) can be assembled in one
vectorised pass, and it applies the paper's operations incrementally:

* :meth:`add_node` - AddNode (eq. 13): a new row/column with no information yet;
* :meth:`add_relative_position`, :meth:`add_range` - AddMeasurement(+) (eqs. 11/12,
  18/19); ranges are linearised at the latest estimates;
* :meth:`add_rotated_position` - a relative position measured in a frame turned by the
  heading held in a third node (INS odometry with a heading state; beyond the paper),
  linearised like a range; :meth:`add_linear` - any linear edge ``y = sum J_n x_n + e``
  (e.g. the heading states' motion model);
* :meth:`delete_node` - DeleteNode(+) by Schur complement (eq. 17): the node's edges are
  replaced by one dense *marginal* edge over its neighbours (ranges frozen at their
  linearisation point);
* :meth:`relinearize` - re-evaluates eqs. 18-21 for ranges whose direction moved and
  rotated positions whose heading moved.

Estimates and covariances (eqs. 4, 5) come from an :class:`IncrementalBlue` kept in step
with every operation; :meth:`assemble` and :func:`batch_blue` give the batch solution of
the same system for checks and benchmarks.

A node becomes *localised* when an edge determines it from localised nodes or anchors (a
relative position, a rotated position, or a linear edge whose block on it is square and
invertible); until then its edges wait (a range alone cannot place a node) and it has no
estimate. Edges are applied in the order the network receives them.
"""
from __future__ import annotations

from collections import defaultdict
from collections.abc import Hashable, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Iterator

import numpy as np
import scipy.sparse as sp

from .batch import BatchBlue, KirchhoffSystem, SingularNetworkError, batch_blue, factorize
from .incremental import IncrementalBlue
from .measurements import (range_blocks, range_direction, range_linearised,
                           relative_position_blocks, rotate_z, rotated_position_linearised,
                           rotated_position_miss)

__all__ = ["GeneralizedElectricalNetwork", "KirchhoffSystem", "batch_blue",
           "SingularNetworkError"]

# edge kinds: relative position, range, marginal, rotated position, linear (the order of
# GeneralizedElectricalNetwork._table)
_POS, _RNG, _MRG, _ROT, _LIN = 0, 1, 2, 3, 4


class _Columns:
    """Growable struct-of-arrays (one row per edge)."""

    def __init__(self, **cols: tuple[tuple[int, ...], type]) -> None:
        self._spec = cols
        self.n = 0
        self._cap = 64
        for name, (shape, dtype) in cols.items():
            setattr(self, name, np.zeros((self._cap, *shape), dtype))

    def _reserve(self, m: int) -> None:
        """Room for ``m`` more rows (capacity doubled as needed)."""
        if self.n + m <= self._cap:
            return
        while self.n + m > self._cap:
            self._cap *= 2
        for name in self._spec:
            old = getattr(self, name)
            new = np.zeros((self._cap, *old.shape[1:]), old.dtype)
            new[:self.n] = old[:self.n]
            setattr(self, name, new)

    def append(self, **values) -> int:
        self._reserve(1)
        for name, value in values.items():
            getattr(self, name)[self.n] = value
        self.n += 1
        return self.n - 1

    def extend(self, m: int, **values) -> np.ndarray:
        """Append ``m`` rows at once; returns their indices."""
        self._reserve(m)
        for name, value in values.items():
            getattr(self, name)[self.n:self.n + m] = value
        self.n += m
        return np.arange(self.n - m, self.n)


@dataclass
class _Marginal:
    """A dense edge over several nodes left by DeleteNode (eq. 17): ``L_NN += lam``,
    ``b_N += eta``."""

    nodes: np.ndarray
    lam: np.ndarray
    eta: np.ndarray
    alive: bool = True
    applied: bool = False


@dataclass
class _Linear:
    """A linear edge ``y = J x_nodes + e``, ``e ~ (0, R)``; ``lam = J^T R^-1 J`` and
    ``eta = J^T R^-1 y`` are its Kirchhoff blocks (eqs. 7, 9)."""

    nodes: np.ndarray
    J: np.ndarray
    R: np.ndarray
    y: np.ndarray
    lam: np.ndarray
    eta: np.ndarray
    alive: bool = True
    applied: bool = False


def _information(what: str, cov: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(information ``cov^-1``, symmetrised ``cov``) of a finite covariance, or a clear
    error when it is not positive definite."""
    cov = 0.5 * (cov + cov.T)
    try:
        info = np.linalg.inv(np.linalg.cholesky(cov))
    except np.linalg.LinAlgError:
        raise ValueError(f"{what}: covariance is not positive definite") from None
    return info.T @ info, cov


class GeneralizedElectricalNetwork:
    """Relative measurement graph with the GEN operations of §IV-C/D and exact estimates.

    Nodes are named by any hashable key. ``dim`` is the position dimension (3 in the
    paper). ``eps`` [m] is the constant in the range Jacobian ``h_ij`` (§IV-D).
    ``relinearize_sigma`` is the linearisation error, in range standard deviations, above
    which a range is re-linearised (:meth:`relinearize`). ``max_active_dims`` bounds the
    dense active set of the incremental solver before the sparse system is refactorised;
    ``hot_nodes`` recently touched nodes are re-activated after each refactorisation.
    ``incremental=False`` gives the plain batch BLUE instead (everything re-solved on the
    first query after a change), as a reference.

    ``rebuild_lag`` > 0 moves the factorisation of systems with at least
    ``background_dims`` dimensions off the caller's thread: :meth:`rebuild` assembles the
    system (re-linearising the stale edges) and hands it to a worker; until the hand-over
    the estimates stay those of the previous factorisation (:attr:`rebuild_pending`), and
    the hand-over happens in the ``rebuild_lag``-th :meth:`relinearize` call after it (one
    call per update), or at once when the dense active set grows past twice its bound;
    meanwhile stale edges are re-linearised in the system of the new factor (the worker
    applies the operations of the updates meanwhile to it itself). The hand-over point
    depends only on the calls, never on the worker's timing, so the same inputs give
    identical estimates (the hand-over waits for a late worker); smaller systems are
    refactorised at once.
    ``handover_wait`` [s] bounds that wait instead: a worker not done by then is handed
    over at a later call (:attr:`late_handovers`), which makes the estimates depend on
    the machine's timing. With a lag a refactorisation is due once the active set passes
    ``background_start`` of its bound (a fraction): it grows on while pending, and the
    updates' dense cost grows with its square.
    """

    def __init__(self, dim: int = 3, *, eps: float = 1e-6, relinearize_sigma: float = 0.1,
                 max_active_dims: int = 900, hot_nodes: int = 150,
                 incremental: bool = True, rebuild_lag: int = 0,
                 background_dims: int = 300, handover_wait: float | None = None,
                 background_start: float = 0.65) -> None:
        if rebuild_lag < 0 or background_dims < 0:
            raise ValueError(f"rebuild_lag ({rebuild_lag}) and background_dims "
                             f"({background_dims}) must be >= 0")
        if not 0 < background_start <= 1:
            raise ValueError(f"background_start must be in (0, 1], got {background_start}")
        if handover_wait is not None and not handover_wait >= 0:
            raise ValueError(f"handover_wait must be >= 0 s or None, got {handover_wait}")
        self.handover_wait = handover_wait
        self.d = dim
        self.eps = eps
        self.relinearize_sigma = relinearize_sigma
        self.hot_nodes = hot_nodes
        self.rebuild_lag = rebuild_lag
        self.background_dims = background_dims
        self._handover_in = 0
        self._behind: _Behind | None = None      # set while a background rebuild is pending
        #: background rebuilds started, and those handed over early (active set too large)
        self.background_rebuilds = 0
        self.forced_handovers = 0
        #: hand-overs whose worker was not done when due: waited for / moved to a later call
        self.waited_handovers = 0
        self.late_handovers = 0
        self.solver: IncrementalBlue | BatchBlue = (
            IncrementalBlue(dim, max_active_dims=max_active_dims) if incremental
            else BatchBlue(dim, self.assemble))
        if rebuild_lag and incremental:
            self.solver.start_dims = int(background_start * max_active_dims)
            # the first pending refactorisation must not grow the dense set on this thread
            self.solver.reserve(self.solver.pending_capacity)
        self._ids: dict[Hashable, int] = {}
        self._keys: list[Hashable] = []
        self._anchor: dict[int, np.ndarray] = {}
        self._alive: list[bool] = []
        self._localised: list[bool] = []
        d = dim
        self._pos = _Columns(i=((), np.int64), j=((), np.int64), z=((d,), float),
                             cov=((d, d), float), info=((d, d), float),
                             alive=((), bool), applied=((), bool))
        self._rng = _Columns(i=((), np.int64), j=((), np.int64), r=((), float),
                             var=((), float), off=((d,), float), li=((d,), float),
                             lj=((d,), float), alive=((), bool), applied=((), bool))
        self._rot = _Columns(i=((), np.int64), j=((), np.int64), h=((), np.int64),
                             z=((d,), float), cov=((d, d), float), info=((d, d), float),
                             lin=((), float), alive=((), bool), applied=((), bool))
        self._mrg: list[_Marginal] = []
        self._lin: list[_Linear] = []
        self._edges: dict[int, list[tuple[int, int]]] = defaultdict(list)   # node -> edges
        self._waiting: dict[int, list[tuple[int, int]]] = defaultdict(list)  # not localised
        self._deferred: list[tuple[list[int], np.ndarray, np.ndarray, np.ndarray]] = []
        self._batching = 0
        self.dropped_edges = 0
        self.relinearised = 0

    # -- nodes ------------------------------------------------------------------------------
    def _new_id(self, key: Hashable) -> int:
        if key in self:  # a deleted (marginalised) node's key may be used again
            raise ValueError(f"node {key!r} already exists")
        nid = len(self._keys)
        self._ids[key] = nid
        self._keys.append(key)
        self._alive.append(True)
        self._localised.append(False)
        return nid

    def id_of(self, key: Hashable) -> int:
        try:
            nid = self._ids[key]
        except KeyError:
            raise KeyError(f"unknown node {key!r}") from None
        if not self._alive[nid]:
            raise KeyError(f"node {key!r} has been deleted")
        return nid

    def __contains__(self, key: Hashable) -> bool:
        nid = self._ids.get(key)
        return nid is not None and self._alive[nid]

    def is_anchor(self, key: Hashable) -> bool:
        return self.id_of(key) in self._anchor

    def is_localised(self, key: Hashable) -> bool:
        nid = self.id_of(key)
        return nid in self._anchor or self._localised[nid]

    @property
    def nodes(self) -> list[Hashable]:
        """Keys of all live nodes (anchors included), in creation order."""
        return [k for k, a in zip(self._keys, self._alive) if a]

    def add_anchor(self, key: Hashable, position: Sequence[float]) -> None:
        """An anchor: a node whose position is known (the base station, §IV-A)."""
        pos = np.asarray(position, float)
        if pos.shape != (self.d,) or not np.all(np.isfinite(pos)):
            raise ValueError(f"anchor {key!r} needs a finite position of {self.d} values, "
                             f"got {position!r}")
        nid = self._new_id(key)
        self._anchor[nid] = pos
        self._localised[nid] = True

    def add_node(self, key: Hashable) -> None:
        """AddNode (eq. 13): a node with an empty row and column in ``L`` and ``b``."""
        self._new_id(key)

    # -- measurements ---------------------------------------------------------------------
    def add_relative_position(self, i: Hashable, j: Hashable, zeta: Sequence[float],
                              cov: np.ndarray) -> int:
        """AddMeasurement (eqs. 11, 12): ``zeta = x_i - x_j + e``, ``e ~ N(0, cov)``."""
        a, b = self.id_of(i), self.id_of(j)
        z = np.asarray(zeta, float)
        if a == b:
            raise ValueError(f"a relative position needs two different nodes, got {i!r} twice")
        info, cov = self._checked_cov(f"relative position {i!r}-{j!r}", z, cov)
        if a in self._anchor and b in self._anchor:
            raise ValueError(f"both {i!r} and {j!r} are anchors")
        fid = self._pos.append(i=a, j=b, z=z, cov=cov, info=info, alive=True, applied=False)
        self._edges[a].append((_POS, fid))
        self._edges[b].append((_POS, fid))
        self._place(_POS, fid)
        return fid

    def add_rotated_position(self, i: Hashable, j: Hashable, h: Hashable,
                             zeta: Sequence[float], cov: np.ndarray) -> int:
        """AddMeasurement+ of a relative position measured in a turned frame:
        ``x_i - x_j = R_z(psi_h) zeta + e``, ``e ~ N(0, cov)``, where ``psi_h`` [rad] is the
        first component of node ``h`` (a heading correction, counter-clockwise about z).

        Linearised at the latest estimate of ``psi_h`` (eqs. 18-19 with
        ``H = [I, -I, -g e_1^T]``, ``g = dR_z/dpsi zeta``) and re-linearised like a range.
        """
        a, b, c = self.id_of(i), self.id_of(j), self.id_of(h)
        z = np.asarray(zeta, float)
        if len({a, b, c}) < 3:
            raise ValueError(f"a rotated position needs three different nodes, got {i!r}, "
                             f"{j!r}, {h!r}")
        info, cov = self._checked_cov(f"rotated position {i!r}-{j!r}", z, cov)
        if a in self._anchor and b in self._anchor:
            raise ValueError(f"both {i!r} and {j!r} are anchors")
        fid = self._rot.append(i=a, j=b, h=c, z=z, cov=cov, info=info, lin=0.0, alive=True,
                               applied=False)
        for n in (a, b, c):
            self._edges[n].append((_ROT, fid))
        self._place(_ROT, fid)
        return fid

    def add_linear(self, nodes: Sequence[Hashable], J: np.ndarray, cov: np.ndarray,
                   y: Sequence[float]) -> int:
        """AddMeasurement of any linear edge ``y = J [x_n1; x_n2; ...] + e``, ``e ~ N(0, cov)``
        (``J`` of shape (r, d * len(nodes))): ``L_NN += J^T cov^-1 J``,
        ``b_N += J^T cov^-1 y`` (eqs. 7, 9, 11)."""
        ids = [self.id_of(k) for k in nodes]
        J = np.asarray(J, float)
        y = np.asarray(y, float).reshape(-1)
        cov = np.asarray(cov, float)
        r = len(y)
        if not ids or len(set(ids)) != len(ids):
            raise ValueError(f"a linear edge needs distinct nodes, got {list(nodes)!r}")
        if J.shape != (r, self.d * len(ids)) or cov.shape != (r, r):
            raise ValueError(f"linear edge over {list(nodes)!r}: J must be ({r}, "
                             f"{self.d * len(ids)}) and cov ({r}, {r}), got {J.shape} and "
                             f"{cov.shape}")
        if not (np.all(np.isfinite(J)) and np.all(np.isfinite(y))
                and np.all(np.isfinite(cov))):
            raise ValueError(f"linear edge over {list(nodes)!r} is not finite")
        if all(n in self._anchor for n in ids):
            raise ValueError(f"linear edge over anchors only: {list(nodes)!r}")
        w, cov = _information(f"linear edge over {list(nodes)!r}", cov)
        fid = len(self._lin)
        self._lin.append(_Linear(np.asarray(ids, np.int64), J, cov, y, J.T @ w @ J,
                                 J.T @ w @ y))
        for n in ids:
            self._edges[n].append((_LIN, fid))
        self._place(_LIN, fid)
        return fid

    def _checked_cov(self, what: str, z: np.ndarray, cov: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray]:
        """(information, symmetrised covariance) of a d-vector measurement, or a clear error."""
        cov = np.asarray(cov, float)
        if z.shape != (self.d,) or cov.shape != (self.d, self.d):
            raise ValueError(f"{what}: zeta must have shape ({self.d},) and cov ({self.d}, "
                             f"{self.d}), got {z.shape} and {cov.shape}")
        if not (np.all(np.isfinite(z)) and np.all(np.isfinite(cov))):
            raise ValueError(f"{what} is not finite")
        return _information(what, cov)

    def add_range(self, i: Hashable, j: Hashable, r: float, var: float,
                  offset: Sequence[float] | None = None) -> int:
        """AddMeasurement+ (eqs. 18, 19): ``r = ||x_i - x_j + offset|| + e``, ``e ~ N(0, var)``,
        linearised at the latest estimates."""
        return int(self.add_ranges([i], [j], [r], [var],
                                   None if offset is None else [offset])[0])

    def add_ranges(self, i: Sequence[Hashable], j: Sequence[Hashable], r: Sequence[float],
                   var: Sequence[float], offset: np.ndarray | None = None) -> np.ndarray:
        """:meth:`add_range` for m ranges at once (one vectorised linearisation and one
        rank-m update); returns their edge ids."""
        a = np.array([self.id_of(k) for k in i], np.int64)
        b = np.array([self.id_of(k) for k in j], np.int64)
        r = np.asarray(r, float).reshape(-1)
        var = np.asarray(var, float).reshape(-1)
        m = len(a)
        if not (len(b) == len(r) == len(var) == m):
            raise ValueError(f"add_ranges: {m} first nodes, {len(b)} second nodes, {len(r)} "
                             f"ranges and {len(var)} variances; they must agree")
        off = np.zeros((m, self.d)) if offset is None else np.asarray(offset, float)
        if off.shape != (m, self.d) or not np.all(np.isfinite(off)):
            raise ValueError(f"range offsets must be finite with shape ({m}, {self.d})")
        for k in range(m):
            if a[k] == b[k]:
                raise ValueError(f"a range needs two different nodes, got {i[k]!r} twice")
            if not (np.isfinite(r[k]) and r[k] >= 0 and np.isfinite(var[k]) and var[k] > 0):
                raise ValueError(f"range {i[k]!r}-{j[k]!r}: need r >= 0 and var > 0, got "
                                 f"{r[k]}, {var[k]}")
            if a[k] in self._anchor and b[k] in self._anchor:
                raise ValueError(f"both {i[k]!r} and {j[k]!r} are anchors")
        if m == 0:
            return np.zeros(0, np.int64)
        fids = self._rng.extend(m, i=a, j=b, r=r, var=var, off=off, alive=True, applied=False)
        for k, f in enumerate(fids):
            self._edges[int(a[k])].append((_RNG, int(f)))
            self._edges[int(b[k])].append((_RNG, int(f)))
        self._maybe_rebuild()
        loc = np.asarray(self._localised)
        ready = loc[a] & loc[b]
        for k in np.flatnonzero(~ready):
            for n in (int(a[k]), int(b[k])):
                if not self._localised[n]:
                    self._waiting[n].append((_RNG, int(fids[k])))
        self._apply_ranges(fids[ready])
        return fids

    def _edge_nodes(self, kind: int, fid: int) -> list[int]:
        if kind == _POS:
            return [int(self._pos.i[fid]), int(self._pos.j[fid])]
        if kind == _RNG:
            return [int(self._rng.i[fid]), int(self._rng.j[fid])]
        if kind == _ROT:
            return [int(self._rot.i[fid]), int(self._rot.j[fid]), int(self._rot.h[fid])]
        if kind == _LIN:
            return [int(n) for n in self._lin[fid].nodes]
        return [int(n) for n in self._mrg[fid].nodes]

    def _place(self, kind: int, fid: int) -> None:
        """Apply an edge now, localise a node through it, or let it wait.

        Localising a node releases the edges that waited for it; those may localise
        further nodes, so this works through a queue rather than recursively.
        """
        self._maybe_rebuild()
        queue = [(kind, fid)]
        while queue:
            kind, fid = queue.pop(0)
            if not self._flag(kind, fid, "alive") or self._flag(kind, fid, "applied"):
                continue
            nodes = self._edge_nodes(kind, fid)
            loose = [n for n in nodes if not self._localised[n]]
            if not loose:
                self._apply(kind, fid)
            elif len(loose) == 1 and self._determines(kind, fid, loose[0]):
                self._localise_through(kind, fid, loose[0])
                queue.extend(self._waiting.pop(loose[0], []))
            else:
                for n in loose:
                    if (kind, fid) not in self._waiting[n]:
                        self._waiting[n].append((kind, fid))

    def _determines(self, kind: int, fid: int, node: int) -> bool:
        """Whether edge ``fid`` alone places ``node`` given its other nodes."""
        if kind == _POS:
            return True
        if kind == _ROT:
            return node != int(self._rot.h[fid])
        if kind == _LIN:
            e = self._lin[fid]
            k = int(np.flatnonzero(e.nodes == node)[0])
            blk = e.J[:, k * self.d:(k + 1) * self.d]
            return blk.shape[0] == self.d and np.linalg.cond(blk) < 1e12
        return False

    def _localise_through(self, kind: int, fid: int, new: int) -> None:
        """Border ``new`` into the estimate via edge ``fid``, which determines it:
        ``J_new x_new = y - sum J_m x_m - e`` gives ``x_new = z + sum G_m x_m``."""
        self._flush()
        if kind == _ROT:
            self._rot.lin[fid] = self._psi_estimates(self._rot.h[fid:fid + 1])[0]
        nodes, blocks, R, y = self._edge_blocks(kind, fid)
        k = nodes.index(new)
        inv = np.linalg.inv(blocks[k])
        parents, gains = [], []
        z = inv @ y
        for n, blk in zip(nodes, blocks):
            if n == new:
                continue
            if n in self._anchor:
                z = z - inv @ blk @ self._anchor[n]
            else:
                parents.append(n)
                gains.append(-inv @ blk)
        self.solver.border(new, parents, gains, z, inv @ R @ inv.T)
        self._set_flag(kind, fid, "applied", True)
        self._localised[new] = True

    def _psi_estimates(self, heading_nodes: np.ndarray) -> np.ndarray:
        """Current heading components [rad] of heading nodes (anchors: their first value)."""
        out = np.zeros(len(heading_nodes))
        free = [k for k, n in enumerate(heading_nodes) if int(n) not in self._anchor]
        if free:
            est = self.solver.estimate([int(heading_nodes[k]) for k in free])
            out[free] = est[:, 0]
        for k, n in enumerate(heading_nodes):
            if int(n) in self._anchor:
                out[k] = self._anchor[int(n)][0]
        return out

    def _table(self, kind: int) -> _Columns | list:
        """Where edges of ``kind`` live: a column table or a list of dense edges."""
        return (self._pos, self._rng, self._mrg, self._rot, self._lin)[kind]

    def _flag(self, kind: int, fid: int, name: str) -> bool:
        """The ``alive`` or ``applied`` flag of edge ``fid`` of ``kind``."""
        table = self._table(kind)
        if isinstance(table, list):
            return getattr(table[fid], name)
        return bool(getattr(table, name)[fid])

    def _set_flag(self, kind: int, fid: int, name: str, value: bool) -> None:
        table = self._table(kind)
        if isinstance(table, list):
            setattr(table[fid], name, value)
        else:
            getattr(table, name)[fid] = value

    def _apply(self, kind: int, fid: int) -> None:
        """Hand an edge whose nodes are all localised to the solver (linearising ranges)."""
        if kind == _RNG:
            self._apply_ranges(np.array([fid]))
            return
        if kind == _ROT:
            self._rot.lin[fid] = self._psi_estimates(self._rot.h[fid:fid + 1])[0]
        self._set_flag(kind, fid, "applied", True)
        nodes, J, R, y = self._linear_form(kind, fid)
        if nodes:
            self._defer(nodes, J, R, y)

    def _defer(self, nodes: list[int], J: np.ndarray, R: np.ndarray, y: np.ndarray) -> None:
        self._deferred.append((nodes, J, R, y))
        if not self._batching:
            self._flush()

    def _apply_ranges(self, fids: np.ndarray) -> None:
        """Linearise ranges at the latest estimates (eqs. 18, 19) and hand them over."""
        if len(fids) == 0:
            return
        rng, d = self._rng, self.d
        ii, jj = rng.i[fids], rng.j[fids]
        anchor = self._anchor_mask()
        nodes = list(dict.fromkeys(int(n) for n in np.concatenate([ii, jj]) if not anchor[n]))
        where = np.full(len(self._keys), -1, np.int64)
        where[nodes] = np.arange(len(nodes))
        est = self.solver.estimate(nodes) if nodes else np.zeros((0, d))
        pos = np.zeros((len(self._keys), d))
        pos[nodes] = est
        for nid, p in self._anchor.items():
            pos[nid] = p
        xi, xj = pos[ii], pos[jj]
        rng.li[fids], rng.lj[fids] = xi, xj
        rng.applied[fids] = True
        h, y = range_linearised(rng.r[fids], xi, xj, rng.off[fids], self.eps)
        m = len(fids)
        J = np.zeros((m, len(nodes) * d))
        rows = np.arange(m)
        for ends, sign in ((ii, 1.0), (jj, -1.0)):
            free = ~anchor[ends]
            cols = where[ends[free]][:, None] * d + np.arange(d)
            J[rows[free][:, None], cols] = sign * h[free]
            fixed = ~free                        # anchors fold into y (eq. 12)
            y[fixed] -= sign * np.einsum("mk,mk->m", h[fixed], pos[ends[fixed]])
        self._defer(nodes, J, np.diag(rng.var[fids]), y)

    def _anchor_mask(self) -> np.ndarray:
        mask = np.zeros(len(self._keys), bool)
        if self._anchor:
            mask[list(self._anchor)] = True
        return mask

    def _edge_blocks(self, kind: int, fid: int, at=None
                     ) -> tuple[list[int], list[np.ndarray], np.ndarray, np.ndarray]:
        """The edge as ``y = sum_n J_n x_n + e``, ``e ~ (0, R)``: its nodes (anchors
        included), their blocks ``J_n``, ``R`` and ``y``. Non-linear edges are taken at their
        linearisation point (eqs. 18-19), or at ``at``: ``(x_i, x_j)`` [m] for a range,
        ``psi`` [rad] for a rotated position. Not for marginal edges."""
        d = self.d
        if kind == _POS:
            t = self._pos
            return ([int(t.i[fid]), int(t.j[fid])], [np.eye(d), -np.eye(d)], t.cov[fid],
                    t.z[fid].copy())
        if kind == _RNG:
            t = self._rng
            li, lj = (t.li[fid], t.lj[fid]) if at is None else at
            h, yv = range_linearised(t.r[fid:fid + 1], np.reshape(li, (1, d)),
                                     np.reshape(lj, (1, d)), t.off[fid], self.eps)
            return ([int(t.i[fid]), int(t.j[fid])], [h, -h], np.array([[t.var[fid]]]), yv)
        if kind == _ROT:
            t = self._rot
            psi = t.lin[fid] if at is None else at
            g, yv = rotated_position_linearised(t.z[fid:fid + 1], np.array([psi], float))
            gh = np.zeros((d, d))
            gh[:, 0] = -g[0]
            return ([int(t.i[fid]), int(t.j[fid]), int(t.h[fid])],
                    [np.eye(d), -np.eye(d), gh], t.cov[fid], yv[0])
        e = self._lin[fid]
        return ([int(n) for n in e.nodes],
                [e.J[:, k * d:(k + 1) * d] for k in range(len(e.nodes))], e.R, e.y.copy())

    def _linear_form(self, kind: int, fid: int, at=None
                     ) -> tuple[list[int], np.ndarray, np.ndarray, np.ndarray]:
        """The edge as ``y = J x_N + e``, ``e ~ (0, R)`` over its non-anchor nodes N, with
        anchors folded into ``y`` (eq. 12); non-linear edges at ``at`` when given (see
        :meth:`_edge_blocks`)."""
        if kind == _MRG:
            m = self._mrg[fid]
            lam, vec = np.linalg.eigh(0.5 * (m.lam + m.lam.T))
            keep = lam > 1e-12 * max(lam.max(initial=0.0), 1e-300)
            if not keep.any():
                return [], np.zeros((0, 0)), np.zeros((0, 0)), np.zeros(0)
            J = vec[:, keep].T
            return ([int(n) for n in m.nodes], J, np.diag(1.0 / lam[keep]),
                    (J @ m.eta) / lam[keep])
        all_nodes, blocks, R, y = self._edge_blocks(kind, fid, at)
        nodes, cols = [], []
        for n, blk in zip(all_nodes, blocks):
            if n in self._anchor:
                y = y - blk @ self._anchor[n]
            else:
                nodes.append(n)
                cols.append(blk)
        return nodes, np.hstack(cols), R, y

    # -- batching -----------------------------------------------------------------------------
    @contextmanager
    def batch(self) -> Iterator[None]:
        """Apply the measurements added inside as one rank-r update (same result, faster).

        Ranges added inside are linearised at the estimates from before the batch.
        """
        self._batching += 1
        try:
            yield
        finally:
            self._batching -= 1
            if not self._batching:
                self._flush()

    def _flush(self) -> None:
        if not self._deferred:
            return
        items, self._deferred = self._deferred, []
        self.solver.update(*_merged(items, self.d))

    # -- deletion (marginalisation) ---------------------------------------------------------------
    def delete_node(self, key: Hashable) -> None:
        """DeleteNode(+) (eq. 17): marginalise the node out by a Schur complement.

        The node's applied edges are replaced by one marginal edge over its non-anchor
        neighbours; the estimates and covariances of the remaining nodes do not change
        (eq. 15). Edges still waiting for a non-localised node are dropped
        (:attr:`dropped_edges`): they tie this node to a node that has no estimate.
        """
        nid = self.id_of(key)
        if nid in self._anchor:
            raise ValueError(f"{key!r} is an anchor and cannot be deleted")
        self._flush()
        edges = [(k, f) for k, f in self._edges.pop(nid, []) if self._flag(k, f, "alive")]
        applied = [(k, f) for k, f in edges if self._flag(k, f, "applied")]
        self.dropped_edges += len(edges) - len(applied)
        for k, f in edges:
            self._kill(k, f)
        self._alive[nid] = False
        self._waiting.pop(nid, None)
        if not self._localised[nid]:
            return
        self.solver.hide(nid)
        nbrs = list(dict.fromkeys(n for k, f in applied for n in self._edge_nodes(k, f)
                                  if n != nid and n not in self._anchor))
        if not nbrs:
            return
        allnodes = [nid, *nbrs]
        where = {n: k for k, n in enumerate(allnodes)}
        d = self.d
        L = np.zeros((len(allnodes) * d,) * 2)
        b = np.zeros(len(allnodes) * d)
        for k, f in applied:
            if k == _MRG:             # already in information form over non-anchors
                m = self._mrg[f]
                idx = (np.array([where[n] for n in m.nodes])[:, None] * d
                       + np.arange(d)).ravel()
                L[np.ix_(idx, idx)] += m.lam
                b[idx] += m.eta
                continue
            ns, J, R, y = self._linear_form(k, f)
            idx = np.concatenate([np.arange(where[n] * d, (where[n] + 1) * d) for n in ns])
            Rinv_J = np.linalg.solve(R, J)
            L[np.ix_(idx, idx)] += J.T @ Rinv_J
            b[idx] += Rinv_J.T @ y
        L11, L1p, Lpp = L[:d, :d], L[:d, d:], L[d:, d:]
        L11_inv = np.linalg.pinv(L11)
        lam = Lpp - L1p.T @ L11_inv @ L1p
        eta = b[d:] - L1p.T @ L11_inv @ b[:d]
        fid = len(self._mrg)
        self._mrg.append(_Marginal(np.asarray(nbrs, np.int64), 0.5 * (lam + lam.T), eta,
                                   applied=True))
        for n in nbrs:
            self._edges[n].append((_MRG, fid))

    def _kill(self, kind: int, fid: int) -> None:
        self._set_flag(kind, fid, "alive", False)
        for n in self._edge_nodes(kind, fid):
            lst = self._edges.get(n)
            if lst is not None and (kind, fid) in lst:
                lst.remove((kind, fid))

    # -- relinearisation ------------------------------------------------------------------------------
    def _range_candidates(self, mask_nodes: np.ndarray | None) -> np.ndarray:
        rng = self._rng
        n = rng.n
        ok = rng.alive[:n] & rng.applied[:n]
        if mask_nodes is not None:
            ok &= mask_nodes[rng.i[:n]] & mask_nodes[rng.j[:n]]
        return np.flatnonzero(ok)

    def _positions(self, x_nodes: np.ndarray, ids: np.ndarray) -> np.ndarray:
        """``x_nodes[ids]`` with anchors at their known positions."""
        out = x_nodes[ids]
        for nid, pos in self._anchor.items():
            out[ids == nid] = pos
        return out

    def _known_estimates(self) -> tuple[np.ndarray, np.ndarray]:
        """(mask over node ids: active in the solver or an anchor; their estimates [m], per
        node id, zero elsewhere), with the deferred edges applied first."""
        self._flush()
        nn = len(self._keys)
        active = self.solver.active_mask(nn)
        est = np.zeros((nn, self.d))
        act = np.flatnonzero(active)
        est[act] = self.solver.active_estimates(act)
        return active | self._anchor_mask(), est

    def stale_edges(self, tol_sigma: float) -> int:
        """How many non-linear edges among nodes whose estimates are at hand (active in the
        solver, or anchors) are linearised so far from the current estimates that the
        linearisation error exceeds ``tol_sigma`` of their standard deviation: ranges
        (their direction turned) and rotated positions (their heading moved)."""
        known, est = self._known_estimates()
        stale = 0
        cand = self._range_candidates(known)
        if len(cand):
            rng = self._rng
            xi, xj = self._positions(est, rng.i[cand]), self._positions(est, rng.j[cand])
            stale += int(self._stale(cand, rng.li[cand], rng.lj[cand], xi, xj,
                                     tol_sigma).sum())
        cand = self._rotated_candidates(known)
        if len(cand):
            psi = self._positions(est, self._rot.h[cand])[:, 0]
            stale += int(self._rot_stale(cand, self._rot.lin[cand], psi, tol_sigma).sum())
        return stale

    def relinearize(self, tol_sigma: float | None = None) -> int:
        """Re-linearise (eqs. 18-21) the non-linear edges whose linearisation error exceeds
        ``tol_sigma`` of their standard deviation (see :meth:`stale_edges`); returns how
        many were stale among the active nodes.

        The new linearisation is applied in the information form, by re-assembling
        ``L`` and ``b`` (eqs. 20, 21) and refactorising: removing an old linearisation
        from a covariance by a negative update is numerically unstable when the
        direction changed a lot, adding information is not.

        While a background refactorisation is pending the call counts towards its
        hand-over (which it does in the ``rebuild_lag``-th call, returning 0); in the
        others the stale edges are re-linearised in the system of the new factor instead
        (see :meth:`_relinearise_pending`), so the Gauss-Newton steps go on there. The
        call ends an update: the worker is let go on then with what the update logged
        (:meth:`IncrementalBlue.release_log`); a hand-over counts as waited for when the
        worker was behind on what it had before this update (the update's own operations
        it applies while the hand-over waits for them).
        """
        tol = self.relinearize_sigma if tol_sigma is None else tol_sigma
        if self.rebuild_pending:
            self._handover_in -= 1
            if self._handover_in <= 0:
                if self.solver.rebuild_ready():
                    self.finish_rebuild()
                    return 0
                if (self.handover_wait is None
                        or self.solver.rebuild_ready(self.handover_wait)):
                    self.waited_handovers += 1
                    self.finish_rebuild()
                    return 0
                self.late_handovers += 1
            changed = self._relinearise_pending(tol)
            self.solver.release_log()
            return changed
        stale = self.stale_edges(tol)
        if stale:
            self.rebuild(tol)
            if self.rebuild_pending:
                self.solver.release_log()
        return stale

    def _relinearise_pending(self, tol_sigma: float) -> int:
        """Re-linearise, while a background rebuild is pending, the non-linear edges among
        active nodes (and anchors) whose linearisation error at the current estimates
        exceeds ``tol_sigma`` sigmas, in the system the next factor holds; returns how many.

        The worker applies each one to the new factor as one update (the old
        linearisation removed with a negative covariance, the new one added) for the
        edges whose removal keeps its precision (:meth:`_swappable`; the others wait for
        the next refactorisation). The serving factor keeps its linearisation (updating
        it too would cost a rank-r update of its whole active set per call, and the new
        factor has the new one from the hand-over on): its points are kept in
        :class:`_Behind`, so its estimates stay the exact BLUE of the system it holds.
        """
        known, est = self._known_estimates()
        changes = []                    # (kind, fid, old point, new point)
        rng = self._rng
        cand = self._range_candidates(known)
        if len(cand):
            xi, xj = self._positions(est, rng.i[cand]), self._positions(est, rng.j[cand])
            turned = self._stale(cand, rng.li[cand], rng.lj[cand], xi, xj, tol_sigma)
            for k in np.flatnonzero(turned):
                f = int(cand[k])
                turned[k] = self._swappable(_RNG, f, (rng.li[f], rng.lj[f]))
                if turned[k]:
                    changes.append((_RNG, f, (rng.li[f].copy(), rng.lj[f].copy()),
                                    (xi[k], xj[k])))
            f = cand[turned]
            self._behind.hold(_RNG, f, rng.li[f], rng.lj[f])
            rng.li[f], rng.lj[f] = xi[turned], xj[turned]
        rot = self._rot
        cand = self._rotated_candidates(known)
        if len(cand):
            psi = self._positions(est, rot.h[cand])[:, 0]
            turned = self._rot_stale(cand, rot.lin[cand], psi, tol_sigma)
            for k in np.flatnonzero(turned):
                f = int(cand[k])
                turned[k] = self._swappable(_ROT, f, float(rot.lin[f]))
                if turned[k]:
                    changes.append((_ROT, f, float(rot.lin[f]), psi[k]))
            f = cand[turned]
            self._behind.hold(_ROT, f, rot.lin[f])
            rot.lin[f] = psi[turned]
        if not changes:
            return 0
        self.solver.record("update", *self._swap(changes))
        self.relinearised += len(changes)
        return len(changes)

    def _swappable(self, kind: int, fid: int, at) -> bool:
        """Whether an edge's linearisation at ``at`` can be removed by a negative update
        without losing precision: the rest of the graph must know the measured combination
        at least as well as the edge itself (``J Sigma J^T <= R / 2``, judged on the
        serving factor's covariance). Where the edge carries most of that information the
        removal would nearly cancel (the round-off turns covariances indefinite), so it
        waits for the next refactorisation."""
        nodes, J, R, _ = self._linear_form(kind, fid, at)
        if not nodes:
            return True
        A = J @ self.solver.covariance(nodes) @ J.T
        try:
            np.linalg.cholesky(R - 2.0 * A)
        except np.linalg.LinAlgError:
            return False
        return True

    def _swap(self, changes: list[tuple]) -> tuple[list[int], np.ndarray, np.ndarray,
                                                   np.ndarray]:
        """One linear update that replaces each edge's linearisation ``(kind, fid, old,
        new)`` at point ``old`` by the one at ``new``: the old rows with a negative
        covariance, the new ones with the edge's."""
        items = []
        for kind, fid, old, new in changes:
            nodes, J, R, y = self._linear_form(kind, fid, old)
            items.append((nodes, J, -R, y))
            items.append(self._linear_form(kind, fid, new))
        return _merged(items, self.d)

    def _rotated_candidates(self, mask_nodes: np.ndarray | None) -> np.ndarray:
        rot = self._rot
        n = rot.n
        ok = rot.alive[:n] & rot.applied[:n]
        if mask_nodes is not None:
            ok &= mask_nodes[rot.h[:n]]
        return np.flatnonzero(ok)

    def _rot_stale(self, fids: np.ndarray, lin: np.ndarray, psi: np.ndarray,
                   tol_sigma: float) -> np.ndarray:
        """Rotated positions linearised at headings ``lin`` whose linearisation error at
        heading ``psi`` [rad] exceeds ``tol_sigma`` of their horizontal standard deviation."""
        rot = self._rot
        miss = rotated_position_miss(rot.z[fids], lin, psi)
        sigma = np.sqrt(0.5 * (rot.cov[fids, 0, 0] + rot.cov[fids, 1, 1]))
        return miss > tol_sigma * sigma

    def _stale(self, fids: np.ndarray, li: np.ndarray, lj: np.ndarray, xi: np.ndarray,
               xj: np.ndarray, tol_sigma: float) -> np.ndarray:
        """Ranges linearised at ``(li, lj)`` whose linearisation error at ``(xi, xj)`` [m]
        exceeds ``tol_sigma`` sigmas.

        The linearised range ``h_ij (x_i - x_j) = y`` is a plane tangent to the sphere
        ``||x_i - x_j + o|| = r`` at the old direction; where the estimates now lie at an
        angle ``theta`` from it the plane misses the sphere by ``r (1 - cos theta)``.
        """
        rng = self._rng
        h_old, _ = range_direction(li, lj, rng.off[fids], self.eps)
        h_new, _ = range_direction(xi, xj, rng.off[fids], self.eps)
        n_old = np.linalg.norm(h_old, axis=1)
        n_new = np.linalg.norm(h_new, axis=1)
        cos = np.einsum("mk,mk->m", h_old, h_new) / np.maximum(n_old * n_new, 1e-300)
        miss = rng.r[fids] * (1.0 - np.clip(cos, -1.0, 1.0))
        return miss > tol_sigma * np.sqrt(rng.var[fids])

    # -- assembly and refactorisation --------------------------------------------------------------
    def assemble(self, positions: np.ndarray | None = None,
                 tol_sigma: float | None = None) -> KirchhoffSystem:
        """Kirchhoff matrix and ``b`` (eqs. 7, 9, 20, 21) over the live localised nodes.

        With ``positions`` (estimates per node id) the ranges whose linearisation error
        there exceeds ``tol_sigma`` sigmas are first re-linearised (0: all of them).
        """
        self._flush()
        if positions is not None:
            self._relinearise_at(positions, 0.0 if tol_sigma is None else tol_sigma)
        return _assemble(self._tables())

    def _relinearise_at(self, positions: np.ndarray, tol_sigma: float) -> _Behind:
        """Re-linearise at ``positions`` (per node id) the ranges and rotated positions whose
        linearisation error there exceeds ``tol_sigma`` sigmas (eqs. 18-21); returns those
        edges with their previous linearisation points."""
        d = self.d
        behind = _Behind(np.zeros(0, np.int64), np.zeros((0, d)), np.zeros((0, d)),
                         np.zeros(0, np.int64), np.zeros(0))
        rng = self._rng
        sel = self._range_candidates(None)
        if len(sel):
            xi = self._positions(positions, rng.i[sel])
            xj = self._positions(positions, rng.j[sel])
            ok = np.all(np.isfinite(xi), 1) & np.all(np.isfinite(xj), 1)
            turned = np.zeros(len(sel), bool)
            turned[ok] = self._stale(sel[ok], rng.li[sel[ok]], rng.lj[sel[ok]], xi[ok],
                                     xj[ok], tol_sigma)
            f = sel[turned]
            behind.rng, behind.li, behind.lj = f, rng.li[f].copy(), rng.lj[f].copy()
            rng.li[f] = xi[turned]
            rng.lj[f] = xj[turned]
            self.relinearised += len(f)
        rot = self._rot
        sel = self._rotated_candidates(None)
        if len(sel):
            psi = self._positions(positions, rot.h[sel])[:, 0]
            ok = np.isfinite(psi)
            turned = np.zeros(len(sel), bool)
            turned[ok] = self._rot_stale(sel[ok], rot.lin[sel[ok]], psi[ok], tol_sigma)
            f = sel[turned]
            behind.rot, behind.lin = f, rot.lin[f].copy()
            rot.lin[f] = psi[turned]
            self.relinearised += len(f)
        return behind

    def _tables(self) -> _Tables:
        """What the assembly reads, as a snapshot that later changes to the network do not
        touch: the live localised nodes and the live applied edges."""
        nn = len(self._keys)
        anchor = self._anchor_mask()
        unknown = np.asarray(self._alive, bool) & np.asarray(self._localised, bool) & ~anchor

        def live(table: _Columns, *names: str) -> dict[str, np.ndarray]:
            n = table.n
            ok = np.flatnonzero(table.alive[:n] & table.applied[:n])
            return {k: getattr(table, k)[ok] for k in names}   # copies (fancy indexing)

        dense = [(e.nodes, e.lam, e.eta) for e in (*self._mrg, *self._lin)
                 if e.alive and e.applied]
        return _Tables(self.d, self.eps, np.flatnonzero(unknown), nn,
                       {k: v.copy() for k, v in self._anchor.items()},
                       live(self._pos, "i", "j", "z", "info"),
                       live(self._rng, "i", "j", "r", "var", "off", "li", "lj"),
                       live(self._rot, "i", "j", "h", "z", "info", "lin"), dense)

    def _maybe_rebuild(self) -> None:
        if not self.solver.needs_rebuild():
            return
        if not self.rebuild_pending:
            self.rebuild()
        elif self.solver.active_dims > 2 * self.solver.max_active_dims:
            self.forced_handovers += 1
            self.finish_rebuild()

    @property
    def rebuild_pending(self) -> bool:
        """A background refactorisation is under way: the estimates are the exact BLUE of
        the previous factorisation and linearisation (the last good ones), not yet of the
        edges it re-linearises."""
        return isinstance(self.solver, IncrementalBlue) and self.solver.rebuild_pending

    def finish_rebuild(self) -> None:
        """Hand a background refactorisation over now (waiting for it if need be)."""
        if self.rebuild_pending:
            self.solver.finish_rebuild()
        self._behind = None

    def rebuild(self, tol_sigma: float | None = None) -> None:
        """Refactorise: re-linearise stale ranges at the current estimates, assemble,
        factorise (on a worker thread for a large system when ``rebuild_lag`` > 0)."""
        tol_sigma = self.relinearize_sigma if tol_sigma is None else tol_sigma
        self.finish_rebuild()
        self._flush()
        est = self.solver.full_estimate(len(self._keys))
        hot = self.solver.recent_nodes(self._hot_count())
        behind = self._relinearise_at(est, tol_sigma)
        tables = self._tables()
        if (self.rebuild_lag and isinstance(self.solver, IncrementalBlue)
                and len(tables.nodes) * self.d >= self.background_dims):
            self.solver.start_rebuild(lambda: _assemble(tables, coo=True), hot)
            self._handover_in = self.rebuild_lag
            self._behind = behind
            self.background_rebuilds += 1
            return
        system = _assemble(tables)
        self.solver.rebuild(system.L, system.b, system.nodes, hot)

    def cost(self, positions: np.ndarray) -> float:
        """Weighted squared error of every live applied edge at ``positions`` (per node id):
        the non-linear least-squares objective whose minimiser the batch solution is
        (marginal and linear edges up to a constant)."""
        x = positions.copy()
        for nid, p in self._anchor.items():
            x[nid] = p
        total = 0.0
        pos = self._pos
        sel = np.flatnonzero(pos.alive[:pos.n] & pos.applied[:pos.n])
        if len(sel):
            e = pos.z[sel] - (x[pos.i[sel]] - x[pos.j[sel]])
            total += float(np.einsum("mk,mkl,ml->", e, pos.info[sel], e))
        rng = self._rng
        sel = self._range_candidates(None)
        if len(sel):
            diff = x[rng.i[sel]] - x[rng.j[sel]] + rng.off[sel]
            e = rng.r[sel] - np.linalg.norm(diff, axis=1)
            total += float(np.sum(e * e / rng.var[sel]))
        rot = self._rot
        sel = self._rotated_candidates(None)
        if len(sel):
            e = rotate_z(rot.z[sel], x[rot.h[sel], 0]) - (x[rot.i[sel]] - x[rot.j[sel]])
            total += float(np.einsum("mk,mkl,ml->", e, rot.info[sel], e))
        for m in (*self._mrg, *self._lin):
            if m.alive and m.applied:
                v = x[m.nodes].ravel()
                total += float(v @ m.lam @ v - 2.0 * m.eta @ v)
        return total

    def optimize(self, tol: float = 1e-9, max_iter: int = 100) -> int:
        """Batch solution of the non-linear problem: Gauss-Newton on eqs. 20-21 with
        Levenberg-Marquardt damping, every range and rotated position re-linearised at
        each iterate, until the estimates move less than ``tol`` [m]. Returns the
        iterations done; the network's estimates are the optimum afterwards."""
        self.finish_rebuild()
        n = len(self._keys)
        x = self.solver.full_estimate(n)
        cost = self.cost(np.nan_to_num(x))
        lam, it = 0.0, 0
        while it < max_iter:
            it += 1
            system = self.assemble(x, 0.0)
            if len(system.nodes) == 0:
                break
            L, b, nodes = system.L, system.b, system.nodes
            cur = x[nodes].ravel()
            rhs = b - L @ cur
            while True:
                A = L + lam * sp.diags(L.diagonal()) if lam else L
                step = factorize(A).solve(rhs)
                trial = x.copy()
                trial[nodes] = (cur + step).reshape(-1, self.d)
                new_cost = self.cost(np.nan_to_num(trial))
                if new_cost <= cost * (1 + 1e-12) or np.max(np.abs(step)) < tol:
                    break
                lam = max(10.0 * lam, 1e-4)
                if lam > 1e8:
                    break
            x, cost = trial, new_cost
            lam = lam / 10.0 if lam > 1e-4 else 0.0
            if np.max(np.abs(step)) < tol:
                break
        system = self.assemble(x, 0.0)
        self.solver.rebuild(system.L, system.b, system.nodes,
                            self.solver.recent_nodes(self._hot_count()))
        return it

    def _hot_count(self) -> int:
        """Nodes to re-activate after a refactorisation: at most half the active set at
        which the next one is due."""
        return min(self.hot_nodes, self.solver.start_dims // (2 * self.d))

    @property
    def node_count(self) -> int:
        """Live nodes, anchors included."""
        return sum(self._alive)

    # -- results ------------------------------------------------------------------------------------
    def estimate(self, key: Hashable) -> np.ndarray:
        """Current BLUE estimate (eq. 4) of a node [m]."""
        nid = self._checked(key)
        if nid in self._anchor:
            return self._anchor[nid].copy()
        self._flush()
        return self.solver.estimate([nid])[0].copy()

    def covariance(self, key: Hashable) -> np.ndarray:
        """Covariance block ``Sigma_ii`` (eq. 5) of a node [m^2]; zero for anchors."""
        nid = self._checked(key)
        if nid in self._anchor:
            return np.zeros((self.d, self.d))
        self._flush()
        return self.solver.covariance([nid])

    def joint_covariance(self, keys: Sequence[Hashable]) -> np.ndarray:
        """Joint covariance of several non-anchor nodes (eq. 5)."""
        ids = [self._checked(k) for k in keys]
        if any(n in self._anchor for n in ids):
            raise ValueError("joint_covariance takes non-anchor nodes only")
        self._flush()
        return self.solver.covariance(ids)

    def estimates_of(self, keys: Sequence[Hashable]) -> np.ndarray:
        """Current estimates (k, d) of several nodes at once (anchors at their position)."""
        ids = [self._checked(k) for k in keys]
        self._flush()
        out = np.zeros((len(ids), self.d))
        free = [k for k, n in enumerate(ids) if n not in self._anchor]
        if free:
            out[free] = self.solver.estimate([ids[k] for k in free])
        for k, n in enumerate(ids):
            if n in self._anchor:
                out[k] = self._anchor[n]
        return out

    def covariances_of(self, keys: Sequence[Hashable]) -> np.ndarray:
        """Covariance blocks (k, d, d) of several nodes at once (eq. 5; zero for anchors)."""
        ids = [self._checked(k) for k in keys]
        self._flush()
        out = np.zeros((len(ids), self.d, self.d))
        free = [k for k, n in enumerate(ids) if n not in self._anchor]
        if free:
            out[free] = self.solver.marginal_covariances([ids[k] for k in free])
        return out

    def estimates(self) -> dict[Hashable, np.ndarray]:
        """Current estimates of every live localised node (one solve for all)."""
        self._flush()
        est = self.solver.full_estimate(len(self._keys))
        out = {}
        for nid, key in enumerate(self._keys):
            if not self._alive[nid]:
                continue
            if nid in self._anchor:
                out[key] = self._anchor[nid].copy()
            elif self._localised[nid]:
                out[key] = est[nid]
        return out

    def _checked(self, key: Hashable) -> int:
        nid = self.id_of(key)
        if not (nid in self._anchor or self._localised[nid]):
            raise KeyError(f"node {key!r} has no estimate yet: no relative-position edge "
                           "ties it to the base station or a localised node")
        return nid

    def edge_count(self) -> dict[str, int]:
        """Live edges by kind (applied or waiting)."""
        return {"relative_position": int(self._pos.alive[:self._pos.n].sum()),
                "range": int(self._rng.alive[:self._rng.n].sum()),
                "rotated_position": int(self._rot.alive[:self._rot.n].sum()),
                "linear": sum(e.alive for e in self._lin),
                "marginal": sum(m.alive for m in self._mrg)}

    def key_of(self, nid: int) -> Hashable:
        return self._keys[nid]


def _merged(items: list[tuple[list[int], np.ndarray, np.ndarray, np.ndarray]], d: int
            ) -> tuple[list[int], np.ndarray, np.ndarray, np.ndarray]:
    """Linear edges ``y_k = J_k x_{N_k} + e_k`` as one: the union of their nodes, ``J``
    stacked, ``R`` block-diagonal, ``y`` stacked."""
    if len(items) == 1:
        return items[0]
    nodes = list(dict.fromkeys(n for it in items for n in it[0]))
    where = {n: k for k, n in enumerate(nodes)}
    rows = sum(len(it[3]) for it in items)
    J = np.zeros((rows, len(nodes) * d))
    R = np.zeros((rows, rows))
    y = np.zeros(rows)
    r0 = 0
    for ns, Jk, Rk, yk in items:
        r1 = r0 + len(yk)
        for c, n in enumerate(ns):
            J[r0:r1, where[n] * d:(where[n] + 1) * d] = Jk[:, c * d:(c + 1) * d]
        R[r0:r1, r0:r1] = Rk
        y[r0:r1] = yk
        r0 = r1
    return nodes, J, R, y


@dataclass
class _Behind:
    """The linearisation points the serving factor still holds for the edges re-linearised
    since a pending background rebuild's snapshot (by the snapshot or for the replay;
    sorted edge ids; ranges: the two nodes' positions [m], rotated positions: the heading
    [rad])."""

    rng: np.ndarray
    li: np.ndarray
    lj: np.ndarray
    rot: np.ndarray
    lin: np.ndarray

    def hold(self, kind: int, fids: np.ndarray, *points: np.ndarray) -> None:
        """Keep the serving factor's points ``points`` (ranges: ``li``, ``lj``; rotated
        positions: ``lin``) of edges ``fids`` about to be re-linearised, unless held
        already (then the serving factor is further behind)."""
        names = ("rng", "li", "lj") if kind == _RNG else ("rot", "lin")
        have = getattr(self, names[0])
        new = ~np.isin(fids, have)
        if not new.any():
            return
        ids = np.concatenate([have, fids[new]])
        order = np.argsort(ids, kind="stable")
        setattr(self, names[0], ids[order])
        for name, p in zip(names[1:], points):
            setattr(self, name, np.concatenate([getattr(self, name), p[new]])[order])


@dataclass
class _Tables:
    """A snapshot of what the assembly of ``L`` and ``b`` reads (see
    :meth:`GeneralizedElectricalNetwork._tables`); edge columns hold live applied edges only."""

    d: int
    eps: float
    nodes: np.ndarray                       # ids of the live localised non-anchor nodes
    n_ids: int
    anchors: dict[int, np.ndarray]
    pos: dict[str, np.ndarray]
    rng: dict[str, np.ndarray]
    rot: dict[str, np.ndarray]
    dense: list[tuple[np.ndarray, np.ndarray, np.ndarray]]   # (nodes, lam, eta)


def _assemble(t: _Tables, coo: bool = False) -> KirchhoffSystem:
    """Kirchhoff matrix and ``b`` (eqs. 7, 9, 20, 21) of a table snapshot, on any thread.
    ``coo``: ``L`` as the unsorted blocks with duplicates (a ``coo_matrix``), leaving their
    summation to whoever factorises it."""
    d, nn, nodes = t.d, t.n_ids, t.nodes
    col = np.full(nn, -1, np.int64)
    col[nodes] = np.arange(len(nodes))
    anchor_pos = np.zeros((nn, d))
    is_anchor = np.zeros(nn, bool)
    for nid, p in t.anchors.items():
        anchor_pos[nid] = p
        is_anchor[nid] = True
    rows_i, rows_j, blocks = [], [], []
    bvec = np.zeros(len(nodes) * d)

    def add(i, j, blk, bi):
        # blk (m, d, d) is the edge's Kirchhoff block, bi (m, d) its b-part at node i;
        # L_ij = L_ji = -blk because J_j = -J_i; anchors are folded into b (eq. 12)
        ua, uc = ~is_anchor[i], ~is_anchor[j]
        for na, nc, s_b, ok in ((i, j, 1.0, ua), (j, i, -1.0, uc)):
            rows_i.append(na[ok]); rows_j.append(na[ok]); blocks.append(blk[ok])
            other_anchor = is_anchor[nc] & ok
            contrib = s_b * bi
            contrib[other_anchor] += np.einsum("mkl,ml->mk", blk[other_anchor],
                                               anchor_pos[nc[other_anchor]])
            np.add.at(bvec.reshape(-1, d), col[na[ok]], contrib[ok])
        both = ua & uc
        rows_i.append(i[both]); rows_j.append(j[both]); blocks.append(-blk[both])
        rows_i.append(j[both]); rows_j.append(i[both]); blocks.append(-blk[both])

    def add_dense(nodes, lam, eta):
        # m edges over k nodes each: Kirchhoff blocks lam (m, k d, k d) and b-part eta
        # (m, k d) over all their nodes; anchors (at anchor_pos, zero elsewhere) are
        # folded into b: b_a = eta_a - sum_c lam_ac x_c over anchors c (eq. 12)
        k = nodes.shape[1]
        lam = lam.reshape(len(nodes), k, d, k, d)
        eta = eta.reshape(len(nodes), k, d) - np.einsum(
            "makcl,mcl->mak", lam, anchor_pos[nodes])
        for a in range(k):
            free_a = ~is_anchor[nodes[:, a]]
            np.add.at(bvec.reshape(-1, d), col[nodes[free_a, a]], eta[free_a, a])
            for c in range(k):
                ok = free_a & ~is_anchor[nodes[:, c]]
                rows_i.append(nodes[ok, a]); rows_j.append(nodes[ok, c])
                blocks.append(lam[ok, a, :, c, :])

    pos = t.pos
    if len(pos["i"]):
        add(pos["i"], pos["j"], *relative_position_blocks(pos["z"], pos["info"]))
    rng = t.rng
    if len(rng["i"]):
        h, y = range_linearised(rng["r"], rng["li"], rng["lj"], rng["off"], t.eps)
        blk, bi = range_blocks(h, y, 1.0 / rng["var"])
        add(rng["i"], rng["j"], blk, bi)
    rot = t.rot
    if len(rot["i"]):
        g, y = rotated_position_linearised(rot["z"], rot["lin"])
        J = np.zeros((len(rot["i"]), d, 3 * d))
        J[:, :, :d] = np.eye(d)
        J[:, :, d:2 * d] = -np.eye(d)
        J[:, :, 2 * d] = -g
        WJ = rot["info"] @ J
        add_dense(np.stack([rot["i"], rot["j"], rot["h"]], axis=1),
                  np.einsum("mrk,mrl->mkl", J, WJ), np.einsum("mrk,mr->mk", WJ, y))
    by_size = defaultdict(list)           # dense edges stacked by their node count
    for e in t.dense:
        by_size[len(e[0])].append(e)
    for group in by_size.values():
        add_dense(*(np.stack(part) for part in zip(*group)))
    if rows_i:
        ri = col[np.concatenate(rows_i)]
        rj = col[np.concatenate(rows_j)]
        bl = np.concatenate(blocks)
        r = (ri[:, None, None] * d + np.arange(d)[None, :, None]).repeat(d, 2)
        c = (rj[:, None, None] * d + np.arange(d)[None, None, :]).repeat(d, 1)
        L = sp.coo_matrix((bl.ravel(), (r.ravel(), c.ravel())), shape=(len(nodes) * d,) * 2)
    else:
        L = sp.coo_matrix((len(nodes) * d,) * 2)
    if not coo:
        L = L.tocsc()
        L.sum_duplicates()
    return KirchhoffSystem(L, bvec, nodes, d)
