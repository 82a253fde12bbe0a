"""Planar geometry every layer shares: angle wrapping and rigid 2-D transforms.

Conventions: angles in radians, counter-clockwise from +x (east), wrapped to
(-pi, pi]; positions in metres in an ENU frame (x east, y north, z up). Transforms act
on the horizontal components and pass z through unchanged.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

__all__ = ["wrap_angle", "wrap_angles", "rot2", "planar_rotation", "Rigid2D"]


def wrap_angle(angle: float) -> float:
    """``angle`` [rad] wrapped to (-pi, pi] (exactly; ``-pi`` becomes ``pi``)."""
    a = math.remainder(angle, 2.0 * math.pi)
    return math.pi if a == -math.pi else a


def wrap_angles(angles: np.ndarray | float) -> np.ndarray:
    """Element-wise :func:`wrap_angle` of an array [rad] (same convention, (-pi, pi])."""
    a = np.remainder(np.asarray(angles, dtype=float), 2.0 * math.pi)
    a = np.where(a > math.pi, a - 2.0 * math.pi, a)
    return a


def rot2(angle: float) -> np.ndarray:
    """The 2x2 counter-clockwise rotation matrix by ``angle`` [rad]."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s], [s, c]])


def planar_rotation(angle: float, n: int = 3) -> np.ndarray:
    """The n x n matrix that turns the horizontal components (the first two) of a vector
    counter-clockwise by ``angle`` [rad] and leaves the others (z, heading) alone.

    For a position (x, y, z) ``n=3``; for a pose covariance over (x, y, z, heading)
    ``R @ cov @ R.T`` with ``n=4`` expresses it in a frame turned by ``angle``.
    """
    m = np.eye(n)
    m[:2, :2] = rot2(angle)
    return m


@dataclass(frozen=True)
class Rigid2D:
    """A planar rigid transform: rotate by ``angle`` [rad] about the origin, then add
    ``offset`` (2,) [m]. Its homogeneous matrix (the ORCA paper's *update matrix*,
    eq. 8) is::

        [[cos a, -sin a, dx],
         [sin a,  cos a, dy],
         [0,      0,      1]]
    """

    angle: float = 0.0
    offset: np.ndarray = field(default_factory=lambda: np.zeros(2))

    @classmethod
    def rotation_about(cls, angle: float, center: np.ndarray) -> "Rigid2D":
        """Rotation by ``angle`` [rad] about ``center`` (2,) [m]."""
        c = np.asarray(center, float)[:2]
        return cls(angle, c - rot2(angle) @ c)

    @classmethod
    def translation(cls, d: np.ndarray) -> "Rigid2D":
        """Translation by ``d`` (2,) or (3,) [m] (z ignored)."""
        return cls(0.0, np.asarray(d, float)[:2].copy())

    @classmethod
    def mapping(cls, local: np.ndarray, local_heading: float, world: np.ndarray,
                world_heading: float) -> "Rigid2D":
        """The transform taking pose (``local``, ``local_heading``) to (``world``, ``world_heading``)."""
        a = wrap_angle(world_heading - local_heading)
        return cls(a, np.asarray(world, float)[:2] - rot2(a) @ np.asarray(local, float)[:2])

    def apply(self, p: np.ndarray) -> np.ndarray:
        """Map points (..., 2) or (..., 3) [m]; z passes through unchanged."""
        p = np.asarray(p, float)
        out = p.copy()
        out[..., :2] = p[..., :2] @ rot2(self.angle).T + self.offset
        return out

    def rotate(self, v: np.ndarray) -> np.ndarray:
        """Rotate vectors (..., 2) or (..., 3) (no translation): increments, velocities."""
        v = np.asarray(v, float)
        out = v.copy()
        out[..., :2] = v[..., :2] @ rot2(self.angle).T
        return out

    def then(self, other: "Rigid2D") -> "Rigid2D":
        """``other`` applied after ``self`` (``other`` o ``self``)."""
        return Rigid2D(wrap_angle(self.angle + other.angle),
                       rot2(other.angle) @ self.offset + other.offset)

    def inverse(self) -> "Rigid2D":
        """The transform undoing this one."""
        return Rigid2D(wrap_angle(-self.angle), -(rot2(-self.angle) @ self.offset))

    @property
    def matrix(self) -> np.ndarray:
        """The 3x3 homogeneous matrix (eq. 8 of the ORCA paper)."""
        m = np.eye(3)
        m[:2, :2] = rot2(self.angle)
        m[:2, 2] = self.offset
        return m
