"""Measurement models of the relative measurement graph and their linearisation (§IV, §IV-D).

Binary measurements connect nodes i and j (eq. 1, ``z_ij = h(x_i, x_j) + e_ij``):

* relative position (drop links, encounters, odometry without heading states):
  ``zeta_ij = x_i - x_j``, linear, Jacobian blocks ``+I`` and ``-I``;
* rotated relative position (INS odometry with a heading state, beyond the paper):
  ``x_i - x_j = R_z(psi_h) zeta``, where ``psi_h`` is the first component of a third
  node h, the correction of the INS heading. Linearised at ``psi^`` like a range
  (eqs. 18-19): blocks ``+I``, ``-I`` and ``-g e_1^T`` with ``g = dR_z/dpsi(psi^) zeta``,
  ``y = R_z(psi^) zeta - g psi^``;
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


def rotate_z(vectors: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Vectors (m, d) turned counter-clockwise by ``angle`` (m,) [rad] about z (the first two
    components; d = 2 or 3)."""
    v = np.array(vectors, float)
    c, s = np.cos(angle), np.sin(angle)
    x, y = v[:, 0].copy(), v[:, 1].copy()
    v[:, 0] = c * x - s * y
    v[:, 1] = s * x + c * y
    return v


def rotated_position_linearised(zeta: np.ndarray, psi: np.ndarray
                                ) -> tuple[np.ndarray, np.ndarray]:
    """``(g, y)`` of rotated relative positions ``x_i - x_j = R_z(psi_h) zeta`` linearised at
    ``psi`` (m,): the factor reads ``x_i - x_j - g psi_h = y`` with
    ``g = dR_z/dpsi zeta`` (m, d) and ``y = R_z(psi) zeta - g psi`` (m, d)."""
    turned = rotate_z(zeta, psi)
    g = np.zeros_like(turned)
    g[:, 0], g[:, 1] = -turned[:, 1], turned[:, 0]
    return g, turned - g * np.asarray(psi, float)[:, None]


def rotated_position_miss(zeta: np.ndarray, psi_lin: np.ndarray, psi: np.ndarray
                          ) -> np.ndarray:
    """Linearisation error [m] (m,) at heading ``psi`` of rotated positions linearised at
    ``psi_lin``: ``|R(psi) zeta - R(psi_lin) zeta - g (psi - psi_lin)|``
    ``= |zeta_xy| |(cos a - 1, sin a - a)|`` with ``a = psi - psi_lin``."""
    a = np.asarray(psi, float) - np.asarray(psi_lin, float)
    return np.hypot(zeta[:, 0], zeta[:, 1]) * np.hypot(np.cos(a) - 1.0, np.sin(a) - a)
