"""Particle-set arithmetic of the filter: log-weight normalisation, the kernel weight of
new states under an existing set, and the weighted summary of a set (mean pose and
covariance). The particle state itself is :class:`firenav_framework.capabilities.Particles`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from firenav_framework.capabilities.particles import Particles
from firenav_framework.geometry import wrap_angle, wrap_angles

__all__ = ["ParticleSummary", "normalise_log_weights", "local_log_weight"]


def normalise_log_weights(logw: np.ndarray) -> bool:
    """Normalise ``logw`` in place so that sum(exp(logw)) = 1; False if all are -inf."""
    m = np.max(logw)
    if not np.isfinite(m):
        return False
    logw -= m + np.log(np.sum(np.exp(logw - m)))
    return True


def local_log_weight(p: Particles, xy: np.ndarray, yaw: np.ndarray, floor: np.ndarray,
                     sigma_m: float, sigma_rad: float) -> np.ndarray:
    """Log of the kernel-weighted mean weight of ``p``'s particles around each state.

    For new states (M,) — position ``xy`` (M, 2), frame rotation ``yaw``, ``floor`` —
    the average weight the existing set gives to its particles near that state, with a
    Gaussian kernel of ``sigma_m`` per axis and ``sigma_rad`` on the rotation (same floor
    only). A state where the set has no support gets -inf.
    """
    out = np.full(len(xy), -np.inf)
    w = p.weights
    for fl in np.unique(floor):
        sel = np.flatnonzero(floor == fl)
        mine = np.flatnonzero(p.floor == fl)
        if not len(mine):
            continue
        d2 = ((xy[sel, None, 0] - p.xy[None, mine, 0]) ** 2
              + (xy[sel, None, 1] - p.xy[None, mine, 1]) ** 2) / sigma_m ** 2
        dyaw = wrap_angles(yaw[sel, None] - p.yaw[None, mine]) / sigma_rad
        k = np.exp(-0.5 * (d2 + dyaw ** 2))
        ksum = k.sum(axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            out[sel] = np.where(ksum > 1e-300, np.log((k @ w[mine]) / ksum), -np.inf)
    return out


@dataclass(frozen=True)
class ParticleSummary:
    """Weighted mean pose of a particle set with its covariance.

    ``cov`` (4, 4) over (x, y, z, heading); heading statistics are circular (the
    mean is the direction of the weighted mean unit vector, deviations are wrapped
    before squaring). ``floor`` is the floor holding most weight; ``z`` the weighted
    floor elevation. ``spread_m2`` = var_x + var_y, the paper's §V-E signal.
    """

    xy: np.ndarray
    z: float
    heading: float
    cov: np.ndarray
    floor: int
    spread_m2: float

    @classmethod
    def of(cls, p: Particles, heading: np.ndarray, elevation: np.ndarray) -> "ParticleSummary":
        """Summarise ``p`` given each particle's walking ``heading`` and floor ``elevation`` [m]."""
        w = p.weights
        mean_xy = w @ p.xy
        z = float(w @ elevation)
        mh = float(np.arctan2(w @ np.sin(heading), w @ np.cos(heading)))
        dev = np.column_stack([p.xy - mean_xy, elevation - z, wrap_angles(heading - mh)])
        cov = (dev * w[:, None]).T @ dev
        cov = 0.5 * (cov + cov.T)
        floors = np.bincount(p.floor - p.floor.min(), weights=w)
        floor = int(np.argmax(floors) + p.floor.min())
        return cls(xy=mean_xy, z=z, heading=wrap_angle(mh), cov=cov, floor=floor,
                   spread_m2=float(cov[0, 0] + cov[1, 1]))
