"""Exact incremental solution of the Kirchhoff system ``L x = b`` (eqs. 4-5) of a changing GEN.

The paper's operations (§IV-C/D) change only a few blocks of ``L`` and ``b`` at a time.
This solver turns that into speed without ever forming a dense ``n x n`` inverse:

* At a *rebuild* the whole sparse Kirchhoff matrix ``L_f`` is factorised once (SuperLU,
  minimum-degree ordering) and ``x_f = L_f^-1 b_f`` is solved.
* Afterwards every node touched by a change joins the small *active set* A. For A the
  solver keeps the exact current estimate ``x_A`` and the exact joint covariance
  ``Sigma_AA`` (dense, ``t x t`` with ``t = d |A|``), so every change costs ``O(t^2 r)``
  for a rank-``r`` change plus, when a node first becomes active, one triangular solve
  with the factor.

Why this is exact. A new measurement is new information on a few nodes; the marginal of
the active set changes by exactly that information (Woodbury / information filter,
eqs. 18-19). A node j that was untouched since the rebuild has an unchanged conditional
distribution given the old active nodes O (its Markov blanket lies in the untouched
part and O), so ``x_j = x_f,j + w^T (x_O - x_f,O)`` and ``Sigma_jA = w^T Sigma_OA``
with ``w = Sigma_f,OO^-1 Sigma_f,Oj`` taken from the factor. The same identity gives all
untouched estimates with a single solve (:meth:`IncrementalBlue.full_estimate`).

A new node is *bordered* from the edge that introduces it (AddNode, eq. 13, followed by
AddMeasurement, eq. 11): for a relative position ``x_n = x_p + zeta``,
``Sigma_n. = Sigma_p.``, ``Sigma_nn = Sigma_pp + P``, which is exactly the BLUE of the
graph with that edge (likewise for any edge ``x_n = z + sum G_m x_m``). Deleting a node
(marginalisation, eqs. 15/17) leaves the others' marginal untouched, so the solver only
hides it until the next rebuild, where the network passes the Schur-complemented system.

A rebuild can also run *in the background* (:meth:`IncrementalBlue.start_rebuild`): the
sparse factorisation of the assembled system runs on a worker thread (SuperLU and LAPACK
release the GIL) while the current factor and active set keep serving every operation;
those operations are logged, and the worker, once it has installed the new factor in a
solver of its own, applies them to it as they arrive (it *catches up*), so that
:meth:`IncrementalBlue.finish_rebuild` only waits for the last ones and swaps that solver
in. The result is the same as a rebuild at the snapshot followed by the same operations,
whatever the worker's timing: the caller chooses the hand-over point, so a replay of the
same inputs gives identical numbers.

Nodes are small integers (the network's node ids); ``d`` is the block size (3 in the
paper: x, y, z).
"""
from __future__ import annotations

import threading
import weakref
from collections.abc import Callable, Sequence

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .batch import TrailingFactor, factorize


class Refactorisation:
    """The sparse factorisation of an assembled Kirchhoff system ``L x = b`` and its solution
    ``x_f``, ready for :meth:`IncrementalBlue.install` (computed on any thread).

    ``nodes`` are the node ids of the blocks of ``L`` in order (``dim`` dims each); the
    ``hot`` nodes among them are eliminated last and their joint covariance read off the
    factor's trailing block (:class:`~.batch.TrailingFactor`).
    """

    def __init__(self, L: sp.spmatrix, b: np.ndarray, nodes: Sequence[int],
                 hot: Sequence[int], dim: int) -> None:
        self.nodes = np.asarray(nodes, np.int64)
        block = {int(n): k for k, n in enumerate(self.nodes)}
        self.hot = [int(h) for h in dict.fromkeys(hot) if int(h) in block]
        self.hdims = (np.array([block[h] for h in self.hot], np.int64)[:, None] * dim
                      + np.arange(dim)).ravel()
        b = np.asarray(b, float)
        L = sp.csc_matrix(L)
        L.sum_duplicates()
        if not len(self.nodes):
            self.lu: spla.SuperLU | TrailingFactor | None = None
            self.xf = np.zeros(0)
        elif not self.hot:
            self.lu = factorize(L)
            self.xf = self.lu.solve(b)
        else:
            self.lu = TrailingFactor(L, self.hdims, block=dim)
            self.xf = self.lu.solve(b)


class _Worker(threading.Thread):
    """Assembles and factorises one system off the caller's thread, installs it in a solver
    of its own and then *catches up*: applies the operations the caller logs meanwhile
    (:meth:`push`), in their order, so that at the hand-over the caller only swaps that
    solver in. It starts, and goes on, only with what the caller has :meth:`release` d
    (between updates: its sparse solves and Python steps hold the GIL, which would
    stretch an update it overlaps). ``assemble`` returns an object with ``L``, ``b`` and
    ``nodes``; ``touch`` and ``clock`` are the caller's touch counters at the snapshot
    (the order in which the next refactorisation's hot nodes are chosen), ``capacity``
    the active-set dimensions to make room for (at least the caller's); ``end`` the
    chain ends at the snapshot (:meth:`IncrementalBlue.recent_nodes`). Errors are
    kept and re-raised on the caller's thread by :meth:`result`."""

    def __init__(self, assemble: Callable[[], object], hot: list[int], dim: int,
                 max_active_dims: int, touch: np.ndarray, end: np.ndarray, clock: int,
                 capacity: int) -> None:
        super().__init__(name="gen-refactorisation", daemon=True)
        self._assemble, self._hot, self._dim = assemble, hot, dim
        self._max_active_dims, self._touch, self._clock = max_active_dims, touch, clock
        self._end = end
        self._capacity = capacity
        self._cond = threading.Condition()
        self._ops: list[tuple[str, tuple]] = []      # logged by the caller
        self._released = -1          # of them, how many the worker may apply (-1: not
        self._applied = 0            # even the factorisation yet); applied so far
        self._closed = False         # hand-over: apply what is logged, then stop
        self._dropped = False        # the caller is gone: stop now
        self._solver: IncrementalBlue | None = None
        self._error: BaseException | None = None

    def run(self) -> None:
        try:
            with self._cond:
                self._cond.wait_for(lambda: self._released >= 0 or self._dropped)
            if self._dropped:
                return
            system = self._assemble()
            f = Refactorisation(system.L, system.b, system.nodes, self._hot, self._dim)
            solver = IncrementalBlue(self._dim, max_active_dims=self._max_active_dims)
            solver._grow_ids(len(self._touch))
            solver._touch[:len(self._touch)] = self._touch
            solver._end[:len(self._end)] = self._end
            solver._clock = self._clock
            solver.install(f)
            solver.reserve(self._capacity)
            with self._cond:
                self._solver = solver
                self._cond.notify_all()
            while True:
                with self._cond:
                    self._cond.wait_for(lambda: self._closed or self._dropped
                                        or self._applied < self._released)
                    end = len(self._ops) if self._closed else self._released
                    todo = [] if self._dropped else self._ops[self._applied:end]
                if not todo:
                    return
                for op, args in todo:
                    getattr(solver, op)(*args)
                with self._cond:
                    self._applied += len(todo)
                    self._cond.notify_all()
        except BaseException as exc:  # re-raised on the caller's thread at the hand-over
            with self._cond:
                self._error = exc
                self._cond.notify_all()

    def push(self, op: str, args: tuple) -> None:
        """Log one operation (a solver method name and its arguments) for the catch-up."""
        with self._cond:
            self._ops.append((op, args))

    def release(self) -> None:
        """Let the worker go on with everything logged so far (the factorisation first)."""
        with self._cond:
            self._released = len(self._ops)
            self._cond.notify_all()

    def drop(self) -> None:
        """Stop without applying what is left (the caller's solver is gone)."""
        with self._cond:
            self._dropped = True
            self._cond.notify_all()

    def caught_up(self, timeout: float | None) -> bool:
        """Whether the factorisation is done and every released operation applied, waiting
        at most ``timeout`` [s] of wall time (None: until then)."""
        with self._cond:
            return self._cond.wait_for(
                lambda: self._error is not None
                or (self._solver is not None and self._applied >= self._released), timeout)

    def result(self) -> tuple[IncrementalBlue, int]:
        """The caught-up solver and how many logged operations it applied (waits)."""
        with self._cond:
            self._closed = True
            self._released = max(self._released, 0)
            self._cond.notify_all()
        self.join()
        if self._error is not None:
            raise self._error
        return self._solver, self._applied


class IncrementalBlue:
    """Exact BLUE estimate and covariance of a GEN, updated a few nodes at a time."""

    def __init__(self, dim: int = 3, *, max_active_dims: int = 900) -> None:
        self.d = dim
        self.max_active_dims = max_active_dims
        #: active-set dimensions above which a refactorisation is due (at most the bound;
        #: lower when refactorisations run in the background, as the set grows meanwhile)
        self.start_dims = max_active_dims
        # factor of the last rebuild
        self._lu: spla.SuperLU | TrailingFactor | None = None
        self._xf = np.zeros(0)
        self._fblock = np.zeros(0, np.int64)     # node id -> block index in the factor, -1 if not
        # active set: slot k holds dims [k d, (k + 1) d) of Sigma and x
        self._cap = 0
        self._sig = np.zeros((0, 0))
        self._x = np.zeros(0)
        self._slot = np.zeros(0, np.int64)       # node id -> slot, -1 if inactive
        self._slot_node: list[int] = []          # slot -> node id
        self._hidden: set[int] = set()
        # old active nodes (in the factor): their slots, Sigma_f^-1 over them, x_f on them
        self._old_slots: list[int] = []
        self._hinv = np.zeros((0, 0))
        self._xf_old = np.zeros(0)
        self._touch = np.zeros(0, np.int64)      # node id -> counter of the last touch
        self._end = np.zeros(0, bool)            # node id -> the end of a chain (see border)
        self._clock = 0
        self.rebuilds = 0
        self.activated = 0
        # a background rebuild: its worker, which gets every operation logged, and what
        # stops it should this solver be dropped before the hand-over
        self._worker: _Worker | None = None
        self._drop_worker: weakref.finalize | None = None

    # -- bookkeeping ------------------------------------------------------------------
    def _grow_ids(self, n: int) -> None:
        if n <= len(self._slot):
            return
        size = max(n, 2 * len(self._slot), 64)
        for name, fill in (("_slot", -1), ("_fblock", -1), ("_touch", 0), ("_end", False)):
            old = getattr(self, name)
            new = np.full(size, fill, old.dtype)
            new[:len(old)] = old
            setattr(self, name, new)

    def _grow_active(self, dims: int) -> None:
        if dims <= self._cap:
            return
        cap = max(dims, 2 * self._cap, 3 * self.d * 16)
        sig = np.zeros((cap, cap))
        t = self.active_dims
        sig[:t, :t] = self._sig[:t, :t]
        x = np.zeros(cap)
        x[:t] = self._x[:t]
        self._sig, self._x, self._cap = sig, x, cap

    def reserve(self, dims: int) -> None:
        """Room for an active set of ``dims`` dimensions, its memory written now (growing a
        large dense covariance later, and the first writes to fresh pages, cost tens of
        ms on whichever thread does them)."""
        t = self.active_dims
        self._grow_active(dims)
        self._sig[t:] = 0.0
        self._sig[:t, t:] = 0.0

    @property
    def pending_capacity(self) -> int:
        """Active-set dimensions to make room for when refactorisations run in the
        background: while one is pending the set grows up to twice its bound (then the
        hand-over is forced), plus one update's new nodes."""
        return 2 * self.max_active_dims + 3 * self.d * 16

    @property
    def active_dims(self) -> int:
        """Dimension t of the dense active-set covariance."""
        return len(self._slot_node) * self.d

    def is_represented(self, node: int) -> bool:
        return (node < len(self._slot) and node not in self._hidden
                and (self._slot[node] >= 0 or self._fblock[node] >= 0))

    def is_active(self, node: int) -> bool:
        return node < len(self._slot) and self._slot[node] >= 0

    def active_mask(self, n: int) -> np.ndarray:
        """Boolean array over node ids ``0..n-1``: node is in the active set."""
        self._grow_ids(n)
        return self._slot[:n] >= 0

    def needs_rebuild(self) -> bool:
        return self.active_dims > self.start_dims

    def _dims(self, nodes: Sequence[int]) -> np.ndarray:
        """Active-set dims of ``nodes`` (which must be active), in order."""
        slots = self._slot[np.asarray(nodes, np.int64)]
        return (slots[:, None] * self.d + np.arange(self.d)).ravel()

    def _new_slots(self, nodes: Sequence[int]) -> np.ndarray:
        t = self.active_dims
        self._grow_active(t + len(nodes) * self.d)
        for n in nodes:
            self._slot[n] = len(self._slot_node)
            self._slot_node.append(n)
        return np.arange(t, t + len(nodes) * self.d)

    # -- activation: bring untouched nodes into the active set exactly ----------------
    def activate(self, nodes: Sequence[int]) -> None:
        """Make ``nodes`` active (one multi-column solve with the factor for all of them)."""
        self._grow_ids(max(nodes, default=-1) + 1)
        todo = []
        for n in dict.fromkeys(nodes):
            if self._slot[n] >= 0:
                continue
            if n in self._hidden or self._fblock[n] < 0:
                raise KeyError(f"node {n} is not part of the network's estimate")
            todo.append(n)
        if not todo:
            return
        d = self.d
        fdims = (self._fblock[np.asarray(todo)][:, None] * d + np.arange(d)).ravel()
        k = len(fdims)
        old_dims = self._dims([self._slot_node[s] for s in self._old_slots]) \
            if self._old_slots else np.zeros(0, np.int64)
        old_fdims = self._old_fdims()
        cols = self._columns(fdims, np.concatenate([old_fdims, fdims]))
        g = cols[:len(old_fdims)]                        # Sigma_f[O, new]
        gjj = cols[len(old_fdims):]
        w = self._hinv @ g                               # (t_old, k)
        s = gjj - g.T @ w
        s = 0.5 * (s + s.T)
        t = self.active_dims
        new = self._new_slots(todo)
        sig, x = self._sig, self._x
        if len(old_dims):
            cross = w.T @ sig[np.ix_(old_dims, np.arange(t))]        # (k, t)
            sig[new[:, None], np.arange(t)] = cross
            sig[np.arange(t)[:, None], new] = cross.T
            sig[np.ix_(new, new)] = s + cross[:, old_dims] @ w
            x[new] = self._xf[fdims] + w.T @ (x[old_dims] - self._xf_old)
        else:
            sig[np.ix_(new, new)] = s
            x[new] = self._xf[fdims]
        s_inv = np.linalg.inv(s)
        s_inv = 0.5 * (s_inv + s_inv.T)
        ws = w @ s_inv
        t_old = len(old_fdims)
        hinv = np.empty((t_old + k, t_old + k))
        hinv[:t_old, :t_old] = self._hinv + ws @ w.T
        hinv[:t_old, t_old:] = -ws
        hinv[t_old:, :t_old] = -ws.T
        hinv[t_old:, t_old:] = s_inv
        self._hinv = hinv
        self._xf_old = np.concatenate([self._xf_old, self._xf[fdims]])
        self._old_slots.extend(int(self._slot[n]) for n in todo)
        self.activated += len(todo)

    def _columns(self, dims: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """``Sigma_f[rows, dims]`` from the factor (unit right-hand sides)."""
        if isinstance(self._lu, TrailingFactor):
            return self._lu.columns(dims, rows)
        rhs = np.zeros((len(self._xf), len(dims)))
        rhs[dims, np.arange(len(dims))] = 1.0
        return self._lu.solve(rhs)[rows]

    def _old_fdims(self) -> np.ndarray:
        if not self._old_slots:
            return np.zeros(0, np.int64)
        blocks = self._fblock[np.asarray([self._slot_node[s] for s in self._old_slots])]
        return (blocks[:, None] * self.d + np.arange(self.d)).ravel()

    # -- the GEN operations -------------------------------------------------------------
    def border(self, new: int, parents: Sequence[int], gains: Sequence[np.ndarray],
               z: np.ndarray, cov: np.ndarray) -> None:
        """Add node ``new`` through one edge that determines it from localised nodes:
        ``x_new = z + sum_m G_m x_parents[m] + e``, ``e ~ (0, cov)``.

        A relative position from a parent p is ``G = I``; an anchor is folded into ``z``
        (eq. 12), leaving no parents. The edge adds no information on the parents (the new
        node absorbs it), so the BLUE of the others is unchanged and
        ``Sigma_n. = G Sigma_P.``, ``Sigma_nn = G Sigma_PP G^T + cov``.

        The new node becomes the end of a chain, and every parent with an invertible gain
        (which the new node continues: a walker's previous state, its previous heading)
        stops being one; a parent entering through a rank-deficient gain (the heading of
        a rotated odometry edge) stays an end.
        """
        self._grow_ids(new + 1)
        if self.is_represented(new) or new in self._hidden:
            raise ValueError(f"node {new} is already in the estimate")
        parents = list(parents)
        self.record("border", new, parents, [np.array(g, float) for g in gains],
                     np.array(z, float), np.array(cov, float))
        if parents:
            self.activate(parents)
            pd = self._dims(parents)
            G = np.hstack([np.asarray(g, float) for g in gains])
        t = self.active_dims
        nd = self._new_slots([new])
        sig, x = self._sig, self._x
        if not parents:
            sig[nd, :t] = 0.0
            sig[:t, nd] = 0.0
            sig[np.ix_(nd, nd)] = cov
            x[nd] = z
        else:
            cross = G @ sig[pd, :t]
            sig[nd, :t] = cross
            sig[:t, nd] = cross.T
            sig[np.ix_(nd, nd)] = cross[:, pd] @ G.T + cov
            x[nd] = z + G @ x[pd]
        self._touch_nodes([new, *parents])
        self._end[new] = True
        for p, g in zip(parents, gains):
            if np.linalg.matrix_rank(np.asarray(g, float)) == self.d:
                self._end[p] = False

    def update(self, nodes: Sequence[int], J: np.ndarray, R: np.ndarray, y: np.ndarray) -> None:
        """Add the linear(ised) measurement ``y = J x_nodes + e``, ``e ~ (0, R)``.

        In GEN terms ``L_NN += J^T R^-1 J`` and ``b_N += J^T R^-1 y`` (eqs. 11, 18, 19).
        ``R`` may be indefinite: a relinearisation removes the old linearisation with a
        negative "covariance". ``nodes`` must be represented; they are activated.
        """
        self.record("update", list(nodes), np.array(J, float), np.array(R, float),
                     np.array(y, float))
        self.activate(nodes)
        idx = self._dims(nodes)
        t = self.active_dims
        sig, x = self._sig[:t, :t], self._x
        sn = sig[:, idx]                                  # Sigma_:N   (t, n)
        su = sn @ J.T                                     # Sigma_:N J^T  (t, r)
        S = R + J @ su[idx]
        kt = np.linalg.solve(S, su.T)                     # K^T  (r, t)
        nu = y - J @ x[idx]
        x[:t] += kt.T @ nu
        sig -= su @ kt
        self._touch_nodes(nodes)

    def hide(self, node: int) -> None:
        """Forget ``node`` (DeleteNode): the others' marginal does not change (eq. 15)."""
        self.record("hide", node)
        self._hidden.add(node)

    def record(self, op: str, *args) -> None:
        """Log an operation (a method name and its arguments) for the worker of a pending
        background rebuild, which applies it to the new factor; nothing when none is
        pending."""
        if self._worker is not None:
            self._worker.push(op, args)

    def _touch_nodes(self, nodes: Sequence[int]) -> None:
        self._clock += 1
        self._touch[np.asarray(nodes, np.int64)] = self._clock

    # -- results --------------------------------------------------------------------------
    def estimate(self, nodes: Sequence[int]) -> np.ndarray:
        """Current estimates (k, d) of ``nodes`` (activates them)."""
        self.activate(nodes)
        return self._x[self._dims(nodes)].reshape(len(nodes), self.d)

    def covariance(self, nodes: Sequence[int]) -> np.ndarray:
        """Joint covariance (k d, k d) of ``nodes`` (eq. 5), activating them."""
        self.activate(nodes)
        idx = self._dims(nodes)
        return self._sig[np.ix_(idx, idx)].copy()

    def marginal_covariances(self, nodes: Sequence[int]) -> np.ndarray:
        """Per-node covariance blocks (k, d, d) of active or activatable nodes."""
        self.activate(nodes)
        idx = self._dims(nodes).reshape(len(nodes), self.d)
        return self._sig[idx[:, :, None], idx[:, None, :]].copy()

    def active_estimates(self, nodes: np.ndarray) -> np.ndarray:
        """Estimates (k, d) of nodes known to be active (no checks, no activation)."""
        slots = self._slot[nodes]
        return self._x[(slots[:, None] * self.d + np.arange(self.d))]

    def full_estimate(self, n: int) -> np.ndarray:
        """Estimates (n, d) of every node id below ``n``; NaN where not represented.

        One solve with the factor gives all untouched nodes at once (see module doc).
        """
        self._grow_ids(n)
        d = self.d
        out = np.full((n, d), np.nan)
        fb = self._fblock[:n]
        infac = np.flatnonzero(fb >= 0)
        if len(self._xf):
            xf = self._xf.copy()
            if self._old_slots:
                old_dims = self._dims([self._slot_node[s] for s in self._old_slots])
                v = np.zeros(len(xf))
                v[self._old_fdims()] = self._hinv @ (self._x[old_dims] - self._xf_old)
                xf += self._lu.solve(v)
            out[infac] = xf.reshape(-1, d)[fb[infac]]
        act = np.asarray(self._slot_node, np.int64)
        act = act[act < n]
        if len(act):
            out[act] = self.active_estimates(act)
        hidden = [h for h in self._hidden if h < n]
        out[hidden] = np.nan
        return out

    def recent_nodes(self, count: int) -> list[int]:
        """``count`` represented nodes to re-activate after a rebuild: the ends of chains
        first (:meth:`border`: a walker's latest state and heading, a breadcrumb), then
        the others, each most recently touched first. The next edges extend the chains
        from their ends, however long ago an end was last touched (in a team's round of
        updates the others' ranges touch many nodes in between)."""
        order = np.lexsort((-self._touch, ~self._end))[:count + len(self._hidden)]
        return [int(n) for n in order if self._touch[n] > 0 and self.is_represented(int(n))][:count]

    # -- rebuild ----------------------------------------------------------------------------
    def rebuild(self, L: sp.spmatrix, b: np.ndarray, nodes: Sequence[int],
                hot: Sequence[int] = ()) -> None:
        """Factorise a freshly assembled Kirchhoff system and reset the active set.

        ``nodes`` lists the node ids of the blocks of ``L`` in order; ``hot`` nodes are
        re-activated at once because the next changes will touch them: they are
        eliminated last, so their joint covariance is the inverse of the factor's
        trailing block (:class:`~.batch.TrailingFactor`), with no solves.
        """
        if self._worker is not None:
            raise RuntimeError("a background rebuild is pending: finish_rebuild() first")
        self.install(Refactorisation(L, b, nodes, hot, self.d))

    # -- rebuild in the background ---------------------------------------------------------
    @property
    def rebuild_pending(self) -> bool:
        """A background rebuild was started and not handed over yet: the estimates are
        those of the previous factorisation (exact for its linearisation)."""
        return self._worker is not None

    def start_rebuild(self, assemble: Callable[[], object], hot: Sequence[int] = ()) -> None:
        """:meth:`rebuild` of the system ``assemble()`` returns (an object with ``L``, ``b``
        and ``nodes``, built from a snapshot), assembled and factorised on a worker thread
        from the first :meth:`release_log` on, which then applies every operation logged
        since (in order, as released); the current factor keeps serving until
        :meth:`finish_rebuild`."""
        if self._worker is not None:
            raise RuntimeError("a background rebuild is already pending")
        self._worker = _Worker(assemble, list(hot), self.d, self.max_active_dims,
                               self._touch.copy(), self._end.copy(), self._clock,
                               max(self._cap, self.pending_capacity))
        self._drop_worker = weakref.finalize(self, self._worker.drop)
        self._worker.start()

    def release_log(self) -> None:
        """Let the worker of a pending background rebuild start, or apply the operations
        logged so far; call it when this thread has nothing to do for a while (after an
        update), since the worker holds the GIL part of the time."""
        if self._worker is not None:
            self._worker.release()

    def rebuild_ready(self, timeout: float | None = 0.0) -> bool:
        """Whether the pending background rebuild is factorised and has applied every
        operation released so far (:meth:`release_log`), waiting for it at most
        ``timeout`` [s] of wall time (None: until then; True when none is pending)."""
        return self._worker is None or self._worker.caught_up(timeout)

    def finish_rebuild(self) -> int:
        """Release every logged operation, wait until the background rebuild has applied
        them and take its solver over (the result of a rebuild at the snapshot followed by the same
        operations, whatever the worker's timing); returns how many it applied."""
        worker = self._worker
        if worker is None:
            return 0
        self._worker = None
        self._drop_worker.detach()
        solver, applied = worker.result()
        for name in ("_lu", "_xf", "_fblock", "_cap", "_sig", "_x", "_slot", "_slot_node",
                     "_hidden", "_old_slots", "_hinv", "_xf_old", "_touch", "_end",
                     "_clock"):
            setattr(self, name, getattr(solver, name))
        self.rebuilds += 1
        self.activated += solver.activated
        return applied

    def install(self, f: Refactorisation) -> None:
        """Reset the estimate to a factorised system: factor, solution, hot nodes active."""
        nodes = f.nodes
        self._grow_ids(int(nodes.max(initial=-1)) + 1)
        self._fblock[:] = -1
        self._fblock[nodes] = np.arange(len(nodes))
        self._slot[:] = -1
        self._slot_node = []
        self._hidden = set()
        self._old_slots = []
        self._hinv = np.zeros((0, 0))
        self._xf_old = np.zeros(0)
        self.rebuilds += 1
        self._lu, self._xf = f.lu, f.xf
        if not f.hot:
            return
        new = self._new_slots(f.hot)
        self._sig[np.ix_(new, new)] = self._lu.covariance
        self._x[new] = self._xf[f.hdims]
        self._hinv = self._lu.schur.copy()
        self._xf_old = self._xf[f.hdims].copy()
        self._old_slots = [int(self._slot[n]) for n in f.hot]
        self.activated += len(f.hot)
