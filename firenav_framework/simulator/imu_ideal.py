"""Error-free IMU readings from the foot kinematics, in the device frame.

Strapdown physics in a local-level ENU frame fixed to the Earth (flat-Earth,
no transport rate over a building):

* specific force ``f_b = C_n^b (a_n + 2 Omega_ie x v_n - g_n)`` with
  ``g_n = (0, 0, -g)`` (gravity incl. centrifugal), so a resting level device reads
  ``+g`` on its up axis; the Coriolis term only appears when the Earth rate is on;
* angular rate ``w_ib^b = w_nb^b + C_n^b Omega_ie`` with
  ``Omega_ie = w_e (0, cos L, sin L)`` in ENU at latitude ``L``.

The IMU moves with the foot, or (``mount``) with the foot plus its compliant mount
(:mod:`.mount`): then the readings are those of the IMU's own motion.

The device may be mounted with its own axes (``axes``: three letters of F/B/L/R/U/D
saying where the device x, y, z point on the foot, e.g. ``"FRD"`` for a z-down unit)
and a small fixed mounting rotation (``mount_deg``: roll, pitch, yaw of the device
relative to those axes).
"""
from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from .gait import FootKinematics
from .mount import MountMotion, imu_kinematics

EARTH_RATE = 7.2921150e-5  # rad/s, WGS84
STANDARD_GRAVITY = 9.81

_AXIS = {"F": (1, 0, 0), "B": (-1, 0, 0), "L": (0, 1, 0), "R": (0, -1, 0),
         "U": (0, 0, 1), "D": (0, 0, -1)}


def axes_matrix(axes: str) -> np.ndarray:
    """Rotation from the foot FLU frame to device axes named like ``"FRD"``.

    Row i is the direction of device axis i expressed in FLU. Raises ValueError for
    anything that is not a right-handed set of three distinct axes.
    """
    axes = axes.upper()
    if len(axes) != 3 or any(c not in _AXIS for c in axes):
        raise ValueError(f"device axes '{axes}' must be three letters from F, B, L, R, U, D")
    m = np.array([_AXIS[c] for c in axes], float)
    if abs(np.linalg.det(m) - 1.0) > 1e-9:
        raise ValueError(f"device axes '{axes}' are not a right-handed frame "
                         "(e.g. FLU, FRD, RFU, LBU)")
    return m


def device_matrix(axes: str = "FLU", mount_deg: tuple[float, float, float] = (0, 0, 0)
                  ) -> np.ndarray:
    """``C_foot^device``: rotates foot-frame vectors into device axes."""
    mis = Rotation.from_euler("ZYX", [mount_deg[2], mount_deg[1], mount_deg[0]],
                              degrees=True).as_matrix()
    return mis.T @ axes_matrix(axes)


def earth_rate_enu(latitude_deg: float) -> np.ndarray:
    lat = np.radians(latitude_deg)
    return EARTH_RATE * np.array([0.0, np.cos(lat), np.sin(lat)])


def ideal_imu(kin: FootKinematics, *, gravity: float = STANDARD_GRAVITY,
              latitude_deg: float | None = None, device: np.ndarray | None = None,
              mount: MountMotion | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(specific force [m/s^2], angular rate [rad/s]) as (N, 3) arrays in device axes.

    ``latitude_deg=None`` leaves out the Earth rate (and Coriolis); ``device`` is
    :func:`device_matrix` (identity: device axes are the foot's FLU); ``mount`` the
    IMU's motion relative to the foot (None: rigidly on the foot).
    """
    imu = imu_kinematics(kin, mount)
    c_bn = imu.c_bn  # IMU (foot FLU axes) -> ENU
    f_n = imu.acceleration.copy()
    f_n[:, 2] += gravity
    w_b = imu.omega_body
    if latitude_deg is not None:
        w_ie = earth_rate_enu(latitude_deg)
        f_n += 2.0 * np.cross(w_ie, imu.velocity)
        w_b = w_b + np.einsum("nji,j->ni", c_bn, w_ie)
    f_b = np.einsum("nji,nj->ni", c_bn, f_n)
    if device is not None:
        f_b = f_b @ device.T
        w_b = w_b @ device.T
    return f_b, w_b
