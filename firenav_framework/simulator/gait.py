"""Foot kinematics of one instrumented foot, from a table of strides.

The foot alternates between *stance* (foot flat and truly still: zero velocity,
zero angular rate) and *swing* (heel-off, toe-off, swing, heel-strike, foot-flat).
A :class:`StrideTable` lists the swings; the foot holds the end pose of one swing
until the next begins. During a swing (phase ``s`` in [0, 1]) the foot moves with
the profiles of :mod:`.profiles`:

* horizontal travel from ``p0`` to ``p1`` along a beta progress curve (late for
  level walking: the heel lifts and the foot rolls over the toe before it travels),
  plus a small lateral sway (circumduction);
* height: rise between the two stance heights plus a clearance bump (level walk:
  foot leaves early, stairs up: rise early, travel late; stairs down: the reverse);
* pitch: stance pitch change plus a toe-down bump at toe-off and a toe-up bump before
  heel-strike; yaw: heading change over the swing; roll: a small eversion bump.

Orientation is ZYX Euler (yaw ``psi`` about z up, pitch ``theta`` about the foot's y
(left) axis, roll ``phi`` about x (toe)), i.e. ``C_b^n = Rz(psi) Ry(theta) Rx(phi)``
from the foot's FLU frame to ENU. Positive pitch tilts the toe *down* (right-hand
rotation about +y). Everything is analytic: velocity, acceleration and the body
angular rate come from the profile derivatives, so an INS that integrates the
synthetic IMU reproduces the trajectory up to its own integration error.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .profiles import bump, progress

#: Vertical style of a swing: how rise/fall and horizontal travel are timed.
LEVEL, UP, DOWN = 0, 1, 2

#: (a, b) of the horizontal progress, the vertical progress and the clearance bump
#: per vertical style. a < b: early; a > b: late.
_H_PROFILE = {LEVEL: (5.0, 4.0), UP: (5.0, 3.0), DOWN: (3.0, 5.0)}
_V_PROFILE = {LEVEL: (4.0, 4.0), UP: (3.0, 5.0), DOWN: (5.0, 3.0)}
_CLEAR_PROFILE = {LEVEL: (3.0, 4.0), UP: (3.0, 4.0), DOWN: (4.0, 3.0)}
_TOE_OFF = (3.0, 6.0)      # toe-down peak at s = 1/3
_HEEL_STRIKE = (7.0, 3.0)  # toe-up peak at s = 0.7
_ANGLE = (4.0, 4.0)        # stance-to-stance change of yaw/pitch/roll
_ROLL = (4.0, 4.0)
_SWAY = (3.0, 3.0)
#: Heel-strike impact: the heel pad and sole compress and rebound in the last 8 % of
#: the swing (about 50 ms at normal walking), a few-g spike before foot-flat.
_IMPACT_START = 0.92
_IMPACT = (3.0, 3.0)


@dataclass
class StrideTable:
    """K swings of one foot, as arrays (SI units, ENU, radians).

    ``t0``/``t1`` (K,) start and end of each swing [s], with ``t1[k] <= t0[k+1]``;
    ``p0``/``p1`` (K, 3) foot (IMU) position at the stance before and after;
    ``yaw0/yaw1``, ``pitch0/pitch1``, ``roll0/roll1`` (K,) stance orientation before and
    after; ``clearance`` (K,) [m] extra height at mid-swing; ``toe_off`` (K,) [rad]
    toe-down pitch at toe-off; ``heel_strike`` (K,) [rad] toe-up pitch before contact;
    ``roll_amp`` (K,) [rad]; ``sway`` (K,) [m] lateral excursion to the left of travel;
    ``vstyle`` (K,) LEVEL/UP/DOWN; ``motion`` (K,) a label per swing (``walk``,
    ``stairs_up``, ``stairs_down``, ``stairs_down_backward``, ``crawl``, ``posture``...);
    ``impact`` (K,) [m] sole compression at heel strike (0: a soft landing).
    """

    t0: np.ndarray
    t1: np.ndarray
    p0: np.ndarray
    p1: np.ndarray
    yaw0: np.ndarray
    yaw1: np.ndarray
    pitch0: np.ndarray
    pitch1: np.ndarray
    roll0: np.ndarray
    roll1: np.ndarray
    clearance: np.ndarray
    toe_off: np.ndarray
    heel_strike: np.ndarray
    roll_amp: np.ndarray
    sway: np.ndarray
    vstyle: np.ndarray
    motion: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=object))
    impact: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.t0)

    def check(self) -> None:
        """Raise ValueError if the table is not a valid sequence of swings."""
        if np.any(self.t1 <= self.t0):
            raise ValueError("every swing needs t1 > t0")
        if len(self) > 1 and np.any(self.t0[1:] < self.t1[:-1] - 1e-9):
            raise ValueError("swings overlap: t0[k+1] < t1[k]")
        if len(self) > 1:
            jump = np.abs(self.p0[1:] - self.p1[:-1]).max()
            if jump > 1e-9:
                raise ValueError(f"stance position jumps by {jump:.3g} m between swings")
            turn = np.abs(np.column_stack([_wrap(self.yaw0[1:] - self.yaw1[:-1]),
                                           self.pitch0[1:] - self.pitch1[:-1],
                                           self.roll0[1:] - self.roll1[:-1]])).max()
            if turn > 1e-9:
                raise ValueError(f"stance orientation jumps by {turn:.3g} rad between swings")


@dataclass
class FootKinematics:
    """The true motion of the foot (IMU point) at N sample times.

    ``position``, ``velocity``, ``acceleration`` (N, 3) ENU [m, m/s, m/s^2];
    ``euler`` (N, 3) yaw, pitch, roll [rad] (yaw unwrapped); ``omega_body`` (N, 3)
    angular rate of the foot frame relative to the navigation frame, in the foot (FLU)
    frame [rad/s]; ``stance`` (N,) True where the foot is flat and still;
    ``stride`` (N,) index of the current or last swing (-1 before the first).
    """

    t: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    euler: np.ndarray
    omega_body: np.ndarray
    stance: np.ndarray
    stride: np.ndarray


def _wrap(a: np.ndarray) -> np.ndarray:
    return (a + np.pi) % (2 * np.pi) - np.pi


def body_rates(euler: np.ndarray, euler_rate: np.ndarray) -> np.ndarray:
    """Body angular rate (FLU) from ZYX Euler angles and their rates [rad/s]."""
    _, th, ph = euler.T
    dps, dth, dph = euler_rate.T
    sth, cth = np.sin(th), np.cos(th)
    sph, cph = np.sin(ph), np.cos(ph)
    return np.column_stack([dph - dps * sth,
                            dth * cph + dps * cth * sph,
                            -dth * sph + dps * cth * cph])


def euler_matrix(euler: np.ndarray) -> np.ndarray:
    """(N, 3, 3) ``C_b^n = Rz(yaw) Ry(pitch) Rx(roll)`` from ZYX Euler angles (N, 3)."""
    ps, th, ph = np.asarray(euler, float).T
    cps, sps, cth, sth = np.cos(ps), np.sin(ps), np.cos(th), np.sin(th)
    cph, sph = np.cos(ph), np.sin(ph)
    r = np.empty((len(ps), 3, 3))
    r[:, 0, 0] = cps * cth
    r[:, 0, 1] = cps * sth * sph - sps * cph
    r[:, 0, 2] = cps * sth * cph + sps * sph
    r[:, 1, 0] = sps * cth
    r[:, 1, 1] = sps * sth * sph + cps * cph
    r[:, 1, 2] = sps * sth * cph - cps * sph
    r[:, 2, 0] = -sth
    r[:, 2, 1] = cth * sph
    r[:, 2, 2] = cth * cph
    return r


def foot_kinematics(table: StrideTable, t: np.ndarray) -> FootKinematics:
    """Evaluate the foot trajectory of ``table`` at times ``t`` (vectorised).

    Before the first swing and after the last the foot rests at the first start /
    last end pose.
    """
    t = np.asarray(t, float)
    n = len(t)
    K = len(table)
    if K == 0:
        raise ValueError("a stride table needs at least one swing")
    k = np.searchsorted(table.t0, t, side="right") - 1
    kc = np.clip(k, 0, K - 1)
    dur = table.t1[kc] - table.t0[kc]
    s = (t - table.t0[kc]) / dur
    swing = (k >= 0) & (s < 1.0)
    s = np.where(swing, s, np.where(k < 0, 0.0, 1.0))
    inv = 1.0 / dur
    inv2 = inv * inv

    vstyle = table.vstyle[kc]
    prof = lambda tab, i: np.array([tab[v][i] for v in (LEVEL, UP, DOWN)])[vstyle]  # noqa: E731
    uh, uh1, uh2 = progress(s, prof(_H_PROFILE, 0), prof(_H_PROFILE, 1))
    uv, uv1, uv2 = progress(s, prof(_V_PROFILE, 0), prof(_V_PROFILE, 1))
    cz, cz1, cz2 = bump(s, prof(_CLEAR_PROFILE, 0), prof(_CLEAR_PROFILE, 1))
    ua, ua1, ua2 = progress(s, *_ANGLE)
    to, to1, to2 = bump(s, *_TOE_OFF)
    hs, hs1, hs2 = bump(s, *_HEEL_STRIKE)
    rb, rb1, rb2 = bump(s, *_ROLL)
    sw, sw1, sw2 = bump(s, *_SWAY)

    p0, p1 = table.p0[kc], table.p1[kc]
    d = p1 - p0
    # Lateral (left) unit vector of the travel direction; for in-place swings use the
    # mean foot heading instead.
    horiz = np.hypot(d[:, 0], d[:, 1])
    travel = np.where(horiz > 1e-6, np.arctan2(d[:, 1], d[:, 0]),
                      table.yaw0[kc] + 0.5 * _wrap(table.yaw1[kc] - table.yaw0[kc]))
    left = np.column_stack([-np.sin(travel), np.cos(travel)])
    sway = table.sway[kc][:, None] * left

    pos = np.empty((n, 3))
    vel = np.empty((n, 3))
    acc = np.empty((n, 3))
    pos[:, :2] = p0[:, :2] + d[:, :2] * uh[:, None] + sway * sw[:, None]
    vel[:, :2] = (d[:, :2] * uh1[:, None] + sway * sw1[:, None]) * inv[:, None]
    acc[:, :2] = (d[:, :2] * uh2[:, None] + sway * sw2[:, None]) * inv2[:, None]
    h = table.clearance[kc]
    pos[:, 2] = p0[:, 2] + d[:, 2] * uv + h * cz
    vel[:, 2] = (d[:, 2] * uv1 + h * cz1) * inv
    acc[:, 2] = (d[:, 2] * uv2 + h * cz2) * inv2
    if table.impact is not None:
        w = 1.0 - _IMPACT_START
        im, im1, im2 = bump((s - _IMPACT_START) / w, *_IMPACT)  # zero before the window
        depth = table.impact[kc]
        pos[:, 2] -= depth * im
        vel[:, 2] -= depth * im1 / w * inv
        acc[:, 2] -= depth * im2 / (w * w) * inv2

    dyaw = _wrap(table.yaw1 - table.yaw0)[kc]
    dpitch = (table.pitch1 - table.pitch0)[kc]
    droll = (table.roll1 - table.roll0)[kc]
    a_to, a_hs, a_r = table.toe_off[kc], table.heel_strike[kc], table.roll_amp[kc]
    # Yaw is unwrapped along the table so that rates are smooth across +-pi.
    yaw_start = table.yaw0[0] + np.concatenate([[0.0], np.cumsum(_wrap(table.yaw1 - table.yaw0))])
    yaw_base = yaw_start[kc]
    euler = np.column_stack([
        yaw_base + dyaw * ua,
        table.pitch0[kc] + dpitch * ua + a_to * to - a_hs * hs,
        table.roll0[kc] + droll * ua + a_r * rb,
    ])
    euler_rate = np.column_stack([
        dyaw * ua1,
        dpitch * ua1 + a_to * to1 - a_hs * hs1,
        droll * ua1 + a_r * rb1,
    ]) * inv[:, None]
    still = ~swing
    vel[still] = 0.0
    acc[still] = 0.0
    euler_rate[still] = 0.0
    omega = body_rates(euler, euler_rate)
    return FootKinematics(t=t, position=pos, velocity=vel, acceleration=acc, euler=euler,
                          omega_body=omega, stance=still, stride=k)
