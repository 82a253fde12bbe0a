"""The extended Kalman filter of the RFID/MEMS paper (rfid-mems-ekf, "Hybridisation").

State (eq. 1 and a heading rate), building frame, SI units::

    x = [E, N, Z, lambda, dtheta, omega]

E, N, Z [m] the agent's position (Z at floor level, the feet), ``lambda`` the scale factor
of the MEMS step length [-], ``dtheta`` the MEMS heading perturbation [rad] and ``omega``
its rate [rad/s]: the vertical gyro bias a foot INS cannot see (zero-velocity updates do
not observe yaw), left in when no still start calibrated it. The paper's filter is the
first five states (``omega`` held at zero by a zero initial variance).

Process model (eq. 2), written with our heading convention (radians counter-clockwise
from east; the paper's compass heading swaps sin and cos)::

    E' = E + lambda * s * cos(theta + dtheta)
    N' = N + lambda * s * sin(theta + dtheta)
    Z' = Z + dZ
    dtheta' = dtheta + omega * dt

with ``s`` and ``theta`` the MEMS step length and heading. Over several steps between two
synchronous updates the displacement is ``lambda * R(dtheta) @ D`` with ``D`` the sum of
the steps' MEMS displacement vectors ``s_i [cos theta_i, sin theta_i]``, which is exact
for constant ``lambda`` and ``dtheta``.

Measurements: an RFID tag position (3-D, possibly measured at an earlier time: see
:meth:`PdrFilter.update_position`) and the door-crossing heading of eq. (3), a direct
measurement of ``dtheta``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from firenav_framework.geometry import rot2, wrap_angle

__all__ = ["I_E", "I_N", "I_Z", "I_LAMBDA", "I_DTHETA", "I_OMEGA", "N_STATE", "PdrFilter",
           "Update", "drot2"]

I_E, I_N, I_Z, I_LAMBDA, I_DTHETA, I_OMEGA = range(6)
N_STATE = 6


def drot2(a: float) -> np.ndarray:
    """Derivative of :func:`~firenav_framework.geometry.rot2` with respect to the angle."""
    c, s = math.cos(a), math.sin(a)
    return np.array([[-s, -c], [c, -s]])


@dataclass(frozen=True)
class Update:
    """The outcome of one measurement update: the innovation, its normalised squared
    size (Mahalanobis distance squared, over the gated components), whether it was
    applied, and whether the state was re-located first (see ``update_position``)."""

    innovation: np.ndarray
    nis: float
    applied: bool
    relocated: bool = False


class PdrFilter:
    """State (6,) and covariance (6, 6) of one agent, with eq. 2 prediction and updates."""

    def __init__(self, x0: np.ndarray, P0: np.ndarray):
        x0 = np.asarray(x0, float)
        P0 = np.asarray(P0, float)
        if x0.shape != (N_STATE,) or P0.shape != (N_STATE, N_STATE):
            raise ValueError(f"state must be ({N_STATE},) and covariance ({N_STATE}, {N_STATE}), "
                             f"got {x0.shape}, {P0.shape}")
        self.x = x0.copy()
        self.P = P0.copy()

    # -- process model (eq. 2) ---------------------------------------------------------
    def predict(self, D: np.ndarray, dz: float, C_D: np.ndarray, var_z: float,
                var_lambda: float, var_dtheta: float, dt: float = 0.0,
                var_omega: float = 0.0) -> None:
        """Move by the MEMS displacement ``D`` (2,) [m] (sum of the steps since the last
        update, building frame before the heading perturbation) and height change ``dz``
        [m], then let the heading perturbation run at ``omega`` for ``dt`` [s]. ``C_D``
        (2, 2) [m^2] is the covariance of ``D``; ``var_z`` [m^2] that of ``dz``;
        ``var_lambda``, ``var_dtheta`` [rad^2] and ``var_omega`` [rad^2/s^2] the
        random-walk growth of the scale factor, heading perturbation and its rate over
        the interval.
        """
        lam, dth = self.x[I_LAMBDA], self.x[I_DTHETA]
        R, dR = rot2(dth), drot2(dth)
        self.x[:2] += lam * (R @ D)
        self.x[I_Z] += dz
        self.x[I_DTHETA] = wrap_angle(dth + self.x[I_OMEGA] * dt)
        F = np.eye(N_STATE)
        F[:2, I_LAMBDA] = R @ D
        F[:2, I_DTHETA] = lam * (dR @ D)
        F[I_DTHETA, I_OMEGA] = dt
        Q = np.zeros((N_STATE, N_STATE))
        Q[:2, :2] = lam ** 2 * (R @ C_D @ R.T)
        Q[I_Z, I_Z] = var_z
        Q[I_LAMBDA, I_LAMBDA] = var_lambda
        Q[I_DTHETA, I_DTHETA] = var_dtheta
        Q[I_OMEGA, I_OMEGA] = var_omega
        self.P = F @ self.P @ F.T + Q
        self._symmetrise()

    # -- measurements --------------------------------------------------------------------
    def update_position(self, z: np.ndarray, R_meas: np.ndarray, D_since: np.ndarray,
                        dz_since: float, C_since: np.ndarray, gate: float | None = None,
                        relocate: float | None = None) -> Update:
        """RFID position update ("Measurement models / RFID Positioning").

        ``z`` (3,) [m] is where the agent was when the tag was read, which may be a while
        before now: ``D_since`` (2,) [m] is the MEMS displacement walked since then (the
        same kind of vector as in :meth:`predict`), ``dz_since`` [m] the height change,
        ``C_since`` (2, 2) [m^2] the covariance of ``D_since``. The predicted measurement
        is the current position moved back by the process model of that displacement,
        ``[E, N] - lambda R(dtheta) D_since``, so the tag also informs ``lambda`` and
        ``dtheta``. ``gate``: largest horizontal Mahalanobis distance accepted.
        """
        lam, dth = self.x[I_LAMBDA], self.x[I_DTHETA]
        R, dR = rot2(dth), drot2(dth)
        back = lam * (R @ D_since)
        h = np.array([self.x[I_E] - back[0], self.x[I_N] - back[1], self.x[I_Z] - dz_since])
        H = np.zeros((3, N_STATE))
        H[:, :3] = np.eye(3)
        H[:2, I_LAMBDA] = -(R @ D_since)
        H[:2, I_DTHETA] = -lam * (dR @ D_since)
        Rm = np.array(R_meas, float).copy()
        Rm[:2, :2] += lam ** 2 * (R @ C_since @ R.T)
        innov = np.asarray(z, float) - h
        res = self._update(innov, H, Rm, gate, gate_axes=slice(0, 2))
        if res.applied or relocate is None:
            return res
        d2 = float(innov[:2] @ innov[:2])
        self.P[:2, :] = 0.0
        self.P[:, :2] = 0.0
        self.P[:2, :2] = np.eye(2) * d2
        self.P[I_DTHETA, I_DTHETA] += relocate ** 2
        self._update(innov, H, Rm, None)
        return Update(res.innovation, res.nis, True, relocated=True)

    def update_heading(self, z: float, var: float) -> Update:
        """Heading perturbation measured directly (eq. 3): ``z`` [rad], variance [rad^2]."""
        H = np.zeros((1, N_STATE))
        H[0, I_DTHETA] = 1.0
        innov = np.array([wrap_angle(z - self.x[I_DTHETA])])
        return self._update(innov, H, np.array([[var]]), None)

    def set_height(self, z: float, var: float) -> None:
        """Reset the height to ``z`` [m] with variance ``var`` [m^2] (a floor level).

        Z is decoupled from the other states (eq. 2 moves it by counted stairs only, and
        the tag update's height row has its own noise), so a reset is exact."""
        self._reset(I_Z, z, var)

    def reset_scale(self, value: float, var: float) -> None:
        """Return the step-length scale lambda to ``value`` with variance ``var``,
        uncorrelated with the other states (its prior: what it was taught is dropped)."""
        self._reset(I_LAMBDA, value, var)

    def _reset(self, i: int, value: float, var: float) -> None:
        """State ``i`` set to ``value`` with variance ``var``, uncorrelated with the rest."""
        self.x[i] = value
        self.P[i, :] = 0.0
        self.P[:, i] = 0.0
        self.P[i, i] = var

    def _update(self, innov: np.ndarray, H: np.ndarray, Rm: np.ndarray, gate: float | None,
                gate_axes: slice = slice(None)) -> Update:
        S = H @ self.P @ H.T + Rm
        Sg = S[gate_axes, gate_axes]
        ig = innov[gate_axes]
        nis = float(ig @ np.linalg.solve(Sg, ig))
        if gate is not None and nis > gate ** 2:
            return Update(innov, nis, False)
        K = np.linalg.solve(S, H @ self.P).T
        self.x = self.x + K @ innov
        self.x[I_DTHETA] = wrap_angle(self.x[I_DTHETA])
        IKH = np.eye(N_STATE) - K @ H
        self.P = IKH @ self.P @ IKH.T + K @ Rm @ K.T     # Joseph form
        self._symmetrise()
        return Update(innov, nis, True)

    def _symmetrise(self) -> None:
        self.P = 0.5 * (self.P + self.P.T)
