"""An independent dense BLUE of a measurement graph, straight from eqs. 2-5.

Builds the stacked measurement matrix (the transposed incidence matrix A^T (x) I, with
range rows h_ij instead of I), the block-diagonal noise covariance P and solves
``L = A_b P^-1 A_b^T``, ``b = A_b P^-1 z_bar``, ``x = L^-1 b``, ``Sigma = L^-1`` with dense
numpy. Used by the tests as the reference the GEN must reproduce.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class DenseGraph:
    dim: int = 3
    anchors: dict = field(default_factory=dict)       # key -> position
    unknowns: list = field(default_factory=list)      # keys, column order
    rows: list = field(default_factory=list)          # (keys, blocks, z, cov)

    def relative(self, i, j, z, cov):
        d = self.dim
        self.rows.append(((i, j), (np.eye(d), -np.eye(d)), np.asarray(z, float),
                          np.asarray(cov, float)))

    def range_linearised(self, i, j, r, var, xi, xj, eps=0.0):
        """A range linearised at (xi, xj) (eqs. 18-19): ``h = d^T / (|d| + eps)``,
        ``h (x_i - x_j) = r - |d| + h d``."""
        diff = np.asarray(xi, float) - np.asarray(xj, float)
        dist = np.linalg.norm(diff)
        h = (diff / (dist + eps))[None, :]
        y = np.array([r - dist + h[0] @ diff])
        self.rows.append(((i, j), (h, -h), y, np.array([[var]])))

    def solve(self):
        d = self.dim
        col = {k: n for n, k in enumerate(self.unknowns)}
        m = sum(len(z) for _, _, z, _ in self.rows)
        At = np.zeros((m, len(self.unknowns) * d))   # A_b^T
        zbar = np.zeros(m)
        P = np.zeros((m, m))
        r0 = 0
        for keys, blocks, z, cov in self.rows:
            r1 = r0 + len(z)
            zbar[r0:r1] = z
            for k, blk in zip(keys, blocks):
                if k in self.anchors:
                    zbar[r0:r1] -= blk @ self.anchors[k]          # z_bar = z - A_r^T x_r
                else:
                    At[r0:r1, col[k] * d:(col[k] + 1) * d] = blk
            P[r0:r1, r0:r1] = cov
            r0 = r1
        Pinv = np.linalg.inv(P)
        L = At.T @ Pinv @ At                                       # eq. 4
        b = At.T @ Pinv @ zbar
        Sigma = np.linalg.inv(L)                                    # eq. 5
        x = Sigma @ b
        est = {k: x[n * d:(n + 1) * d] for k, n in col.items()}
        return est, Sigma, col
