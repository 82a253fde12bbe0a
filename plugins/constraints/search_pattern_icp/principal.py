"""Rotation of an odometry trajectory onto the building's principal headings (eq. 1).

§IV-D.1 of the search-pattern paper: most walking in rectangular buildings follows
one of four principal headings, so the trajectory is first rotated by

    phi_hat = argmin_phi C(phi),  C(phi) = sum_l dist(theta_l + phi, principal)

where ``theta_l`` is the direction of the displacement x_{l+1} - x_l and ``dist`` the
angular distance to the closest principal heading. The paper writes ``dist`` as the
minimum over |. - pi|, |. - pi/2|, |.|, |. + pi/2|; we take it modulo 2 pi (the
circular distance to the nearest multiple of pi/2 from the building axis), which is
the same for angles in (-3pi/4, pi] and also right near -pi.

C is piecewise linear in phi with its kinks where some theta_l + phi hits a principal
heading, so its minimum lies on one of those kinks: we evaluate C there exactly
instead of on a search grid.
"""
from __future__ import annotations

import numpy as np

__all__ = ["principal_rotation", "quarter_distance"]

_QUARTER = np.pi / 2


def quarter_distance(angle: np.ndarray) -> np.ndarray:
    """Angular distance [rad] from ``angle`` to the nearest multiple of pi/2 (in [0, pi/4])."""
    r = np.mod(angle, _QUARTER)
    return np.minimum(r, _QUARTER - r)


def principal_rotation(xy: np.ndarray, axis_angle: float = 0.0) -> float:
    """The rotation phi_hat [rad] of eq. (1), in [-pi/4, pi/4).

    ``xy`` (P, 2) is the trajectory; ``axis_angle`` the direction of the building's
    principal axes [rad] (0 for a plan drawn along x/y). Zero-length displacements
    carry no direction and are ignored; with none left the rotation is 0.
    """
    d = np.diff(np.asarray(xy, dtype=float), axis=0)
    keep = np.hypot(d[:, 0], d[:, 1]) > 1e-9
    if not keep.any():
        return 0.0
    theta = np.arctan2(d[keep, 1], d[keep, 0]) - axis_angle
    # kinks of C: phi such that theta_l + phi is a principal heading
    cand = np.mod(-theta + np.pi / 4, _QUARTER) - np.pi / 4
    cost = quarter_distance(theta[None, :] + cand[:, None]).sum(axis=1)
    return float(cand[int(np.argmin(cost))])
