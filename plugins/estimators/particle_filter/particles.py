"""The particle arrays of one firefighter and their weighted summary.

Each particle carries (search-pattern paper §IV-E):

* ``xy`` (N, 2): horizontal position in the building's ENU frame [m];
* ``yaw`` (N,): the rotation [rad] from the odometry (INS) frame, whose yaw is
  arbitrary, into the building frame. A particle's walking direction is
  ``yaw + ins_heading - walk_offset`` (see :mod:`.history`), so storing the frame
  rotation instead of the heading itself lets every particle share the INS heading
  and the IMU-to-walking-direction offset while keeping its own alignment;
* ``floor`` (N,): floor index; ``climb`` (N,): vertical travel [m] accumulated on
  stairs towards the next floor change;
* ``scale`` (N,): step-length scale applied to the odometry (1 when disabled);
* ``yaw_rate`` (N,): drift rate of the frame rotation [rad/s] — an INS whose yaw
  gyro bias was not calibrated turns its frame at a constant rate (0 when disabled);
* ``logw`` (N,): normalised log-weights (log-sum-exp = 0), logs because the
  pattern likelihood exp(-E / sigma^2) underflows linear weights.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Particles", "ParticleSummary", "wrap_angle", "normalise_log_weights",
           "local_log_weight"]


def wrap_angle(a: np.ndarray | float) -> np.ndarray | float:
    """Angles wrapped to (-pi, pi]."""
    w = np.mod(np.asarray(a, dtype=float) + np.pi, 2 * np.pi) - np.pi
    w = np.where(w == -np.pi, np.pi, w)
    return float(w) if np.ndim(w) == 0 else w


def normalise_log_weights(logw: np.ndarray) -> bool:
    """Normalise ``logw`` in place so that sum(exp(logw)) = 1; False if all are -inf."""
    m = np.max(logw)
    if not np.isfinite(m):
        return False
    logw -= m + np.log(np.sum(np.exp(logw - m)))
    return True


@dataclass
class Particles:
    """A weighted particle set (see the module docstring for the fields)."""

    xy: np.ndarray
    yaw: np.ndarray
    floor: np.ndarray
    climb: np.ndarray
    scale: np.ndarray
    logw: np.ndarray
    yaw_rate: np.ndarray

    @classmethod
    def create(cls, xy: np.ndarray, yaw: np.ndarray, floor: np.ndarray | int = 0,
               scale: np.ndarray | float = 1.0, yaw_rate: np.ndarray | float = 0.0
               ) -> "Particles":
        """Equally weighted particles from positions and frame rotations."""
        xy = np.array(xy, dtype=float).reshape(-1, 2)
        n = len(xy)
        return cls(xy=xy, yaw=np.array(wrap_angle(np.broadcast_to(yaw, (n,))), dtype=float),
                   floor=np.array(np.broadcast_to(floor, (n,)), dtype=np.int64),
                   climb=np.zeros(n),
                   scale=np.array(np.broadcast_to(scale, (n,)), dtype=float),
                   logw=np.full(n, -np.log(n)) if n else np.zeros(0),
                   yaw_rate=np.array(np.broadcast_to(yaw_rate, (n,)), dtype=float))

    def __len__(self) -> int:
        return len(self.logw)

    @property
    def weights(self) -> np.ndarray:
        """Linear weights (sum 1)."""
        return np.exp(self.logw)

    def copy(self) -> "Particles":
        return Particles(self.xy.copy(), self.yaw.copy(), self.floor.copy(),
                         self.climb.copy(), self.scale.copy(), self.logw.copy(),
                         self.yaw_rate.copy())

    def take(self, idx: np.ndarray) -> "Particles":
        """The particles at ``idx`` (copies; weights as they were, not renormalised)."""
        return Particles(self.xy[idx], self.yaw[idx], self.floor[idx], self.climb[idx],
                         self.scale[idx], self.logw[idx], self.yaw_rate[idx])

    def put(self, idx: np.ndarray, other: "Particles") -> None:
        """Overwrite the particles at ``idx`` with ``other`` (same length as ``idx``)."""
        self.xy[idx] = other.xy
        self.yaw[idx] = other.yaw
        self.floor[idx] = other.floor
        self.climb[idx] = other.climb
        self.scale[idx] = other.scale
        self.yaw_rate[idx] = other.yaw_rate
        self.logw[idx] = other.logw

    def effective_sample_size(self) -> float:
        """1 / sum(w^2) for the normalised weights."""
        w = self.weights
        return float(1.0 / np.sum(w * w))


def local_log_weight(p: "Particles", xy: np.ndarray, yaw: np.ndarray, floor: np.ndarray,
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
        dyaw = wrap_angle(yaw[sel, None] - p.yaw[None, mine]) / sigma_rad
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
        dev = np.column_stack([p.xy - mean_xy, elevation - z, wrap_angle(heading - mh)])
        cov = (dev * w[:, None]).T @ dev
        cov = 0.5 * (cov + cov.T)
        floors = np.bincount(p.floor - p.floor.min(), weights=w)
        floor = int(np.argmax(floors) + p.floor.min())
        return cls(xy=mean_xy, z=z, heading=float(wrap_angle(mh)), cov=cov, floor=floor,
                   spread_m2=float(cov[0, 0] + cov[1, 1]))
