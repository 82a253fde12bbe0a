"""Quaternion and rotation helpers for the strapdown INS (numba, scalar-array style).

Conventions: quaternions are ``[w, x, y, z]`` and rotate body (FLU) vectors into the
navigation frame (ENU): ``v_nav = R(q) @ v_body``. Attitude errors are small rotation
vectors in the *navigation* frame, ``R_true = exp([dtheta]x) @ R_est``. Heading (yaw)
is the ENU angle of the body x axis (toe), counter-clockwise from east.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product ``a ⊗ b``."""
    out = np.empty(4)
    out[0] = a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3]
    out[1] = a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2]
    out[2] = a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1]
    out[3] = a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0]
    return out


@njit(cache=True)
def quat_from_rotvec(x: float, y: float, z: float) -> np.ndarray:
    """Unit quaternion of the rotation vector (x, y, z) [rad] (exact, any angle)."""
    angle = math.sqrt(x * x + y * y + z * z)
    out = np.empty(4)
    if angle < 1e-12:
        # second-order series keeps the result a unit quaternion to rounding
        out[0] = 1.0 - angle * angle / 8.0
        out[1] = 0.5 * x
        out[2] = 0.5 * y
        out[3] = 0.5 * z
        return out
    s = math.sin(0.5 * angle) / angle
    out[0] = math.cos(0.5 * angle)
    out[1] = s * x
    out[2] = s * y
    out[3] = s * z
    return out


@njit(cache=True)
def quat_normalize(q: np.ndarray) -> None:
    """Normalise ``q`` in place (keeps w >= 0 so equal rotations compare equal)."""
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    if q[0] < 0.0:
        n = -n
    for i in range(4):
        q[i] /= n


@njit(cache=True)
def quat_to_mat(q: np.ndarray) -> np.ndarray:
    """Rotation matrix (body -> nav) of a unit quaternion."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    r = np.empty((3, 3))
    r[0, 0] = 1.0 - 2.0 * (y * y + z * z)
    r[0, 1] = 2.0 * (x * y - w * z)
    r[0, 2] = 2.0 * (x * z + w * y)
    r[1, 0] = 2.0 * (x * y + w * z)
    r[1, 1] = 1.0 - 2.0 * (x * x + z * z)
    r[1, 2] = 2.0 * (y * z - w * x)
    r[2, 0] = 2.0 * (x * z - w * y)
    r[2, 1] = 2.0 * (y * z + w * x)
    r[2, 2] = 1.0 - 2.0 * (x * x + y * y)
    return r


@njit(cache=True)
def quat_from_euler(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """Quaternion of ``Rz(yaw) @ Ry(pitch) @ Rx(roll)`` (ZYX Euler angles, rad)."""
    cr, sr = math.cos(0.5 * roll), math.sin(0.5 * roll)
    cp, sp = math.cos(0.5 * pitch), math.sin(0.5 * pitch)
    cy, sy = math.cos(0.5 * yaw), math.sin(0.5 * yaw)
    q = np.empty(4)
    q[0] = cy * cp * cr + sy * sp * sr
    q[1] = cy * cp * sr - sy * sp * cr
    q[2] = cy * sp * cr + sy * cp * sr
    q[3] = sy * cp * cr - cy * sp * sr
    return q


@njit(cache=True)
def yaw_of(q: np.ndarray) -> float:
    """Heading of the body x axis in the navigation frame [rad], in (-pi, pi]."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    return math.atan2(2.0 * (x * y + w * z), 1.0 - 2.0 * (y * y + z * z))


@njit(cache=True)
def tilt_of(q: np.ndarray) -> float:
    """Angle between the body z axis and the navigation up axis [rad], in [0, pi]."""
    c = 1.0 - 2.0 * (q[1] * q[1] + q[2] * q[2])
    return math.acos(min(1.0, max(-1.0, c)))


@njit(cache=True)
def level_quat(fx: float, fy: float, fz: float) -> np.ndarray:
    """Attitude with zero yaw whose body frame sees specific force (fx, fy, fz) as 'up'.

    Roll and pitch from gravity while standing still (coarse alignment); valid for any
    orientation, upside down included.
    """
    roll = math.atan2(fy, fz)
    pitch = math.atan2(-fx, math.sqrt(fy * fy + fz * fz))
    return quat_from_euler(roll, pitch, 0.0)
