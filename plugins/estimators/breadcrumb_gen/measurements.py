"""Measurement models of the relative measurement graph and their linearisation (§IV, §IV-D).

Two binary measurements connect nodes i and j (eq. 1, ``z_ij = h(x_i, x_j) + e_ij``):

* relative position (PDR / INS odometry, drop links, encounters): ``zeta_ij = x_i - x_j``,
  linear, Jacobian blocks ``+I`` and ``-I``;
* relative range (RSSI): ``r_ij = ||x_i - x_j + o_ij||``, non-linear. ``o_ij`` is a
  constant offset between the node positions and the antennas (zero in the paper).
  It is linearised at the latest estimates ``x^`` with (eqs. 18-21)
  ``h_ij = (x^_i - x^_j + o)^T / (||x^_i - x^_j + o|| + eps)`` and the linearised
  measurement ``y = r - h(x^) + h_ij (x^_i - x^_j)``.

Every function here is vectorised over m measurements, so the whole Kirchhoff matrix
can be assembled without a Python loop per edge. A measurement contributes
``J^T W J`` to ``L`` and ``J^T W y`` to ``b`` (eqs. 7, 9, 20, 21) with ``J = [J_i, J_j]``.
"""
from __future__ import annotations

import numpy as np


def range_direction(xi: np.ndarray, xj: np.ndarray, offset: np.ndarray,
                    eps: float) -> tuple[np.ndarray, np.ndarray]:
    """Row Jacobian ``h_ij`` (m, d) and predicted range ``||x_i - x_j + o||`` (m,).

    ``eps`` is the paper's small constant in the denominator of ``h_ij`` (§IV-D); it
    keeps the Jacobian finite when two estimates coincide (the direction is then
    unobservable and ``h_ij`` tends to zero, i.e. the range carries no information).
    """
    diff = np.asarray(xi, float) - np.asarray(xj, float) + offset
    dist = np.sqrt(np.einsum("...k,...k->...", diff, diff))
    return diff / (dist + eps)[..., None], dist


def range_linearised(r: np.ndarray, xi: np.ndarray, xj: np.ndarray, offset: np.ndarray,
                     eps: float) -> tuple[np.ndarray, np.ndarray]:
    """``(h_ij, y)`` of range measurements linearised at ``(xi, xj)`` (eqs. 18-21).

    With this ``y`` the factor reads ``h_ij (x_i - x_j) = y`` (the offset is folded in):
    ``y = r - h(x^) + h_ij (x^_i - x^_j)``.
    """
    h, dist = range_direction(xi, xj, offset, eps)
    y = np.asarray(r, float) - dist + np.einsum("...k,...k->...", h, np.asarray(xi, float)
                                                - np.asarray(xj, float))
    return h, y


def relative_position_blocks(z: np.ndarray, info: np.ndarray
                             ) -> tuple[np.ndarray, np.ndarray]:
    """Kirchhoff block ``P^-1`` (m, d, d) and the b-contribution ``P^-1 zeta`` (m, d) of
    relative-position edges (eqs. 7, 9, 11): node i gets ``+block`` on its diagonal and
    ``+P^-1 zeta``, node j ``+block`` and ``-P^-1 zeta``, and ``L_ij = L_ji = -block``."""
    return info, np.einsum("mkl,ml->mk", info, z)


def range_blocks(h: np.ndarray, y: np.ndarray, w: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Kirchhoff block ``h^T w h`` (m, d, d) and b-contribution ``h^T w y`` (m, d) of range
    edges (eqs. 20, 21), with ``w = 1 / var`` the measurement information."""
    return (w[:, None, None] * h[:, :, None] * h[:, None, :],
            (w * y)[:, None] * h)
