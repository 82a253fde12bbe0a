"""Foot kinematics of one instrumented foot, from a table of strides.

The foot is a rigid body that alternates between *flat stance* (foot flat and truly
still: zero velocity, zero angular rate) and a *moving phase* from heel-off to
foot-flat. A :class:`StrideTable` lists the moving phases (``t0`` heel-off, ``t1``
foot-flat); the foot holds the end pose of one until the next begins. Each moving
phase (phase ``s`` in [0, 1]) has three parts, as in the gait literature's three
rockers (Perry, *Gait Analysis*, ch. 3):

* **toe rocker** (heel-off to toe-off, ``toe_rocker`` seconds: terminal stance and
  pre-swing, about 20-30 % of the gait cycle): the foot rotates about the ball of the
  foot (metatarsal heads), which stays on the floor; the heel rises slowly, then fast;
* **swing** (airborne): the ball leaves the floor, the foot plantarflexes a little
  further, rotates toe-up, travels to the next footfall and turns to its new heading;
* **heel rocker** (heel strike to foot-flat, ``heel_rocker`` seconds: the loading
  response, about 10 % of the gait cycle): the foot lands toe-up on the heel and
  rotates about it down to flat (the foot slap), while heel pad and sole give way down
  and forward by ``impact`` (the heel-strike transient, 3-4 g at normal walking).

During both rockers the foot is on the ground but **not** still: the IMU, mounted on
the instep between heel and ball, moves on an arc about the contact point. Only the
flat stance between foot-flat and the next heel-off is still. With zero rocker
durations the foot lifts off and lands flat (an idealised foot).

Pitch passes through knots with zero rate: stance pose at heel-off, maximum
plantarflexion (``toe_off``, toe-down) shortly after toe-off, maximum dorsiflexion
(``heel_strike``, toe-up) just before heel strike, stance pose at foot-flat. Roll
inverts by ``roll_amp`` (signed: the Walker gives each foot its sign) by toe-off,
holds through most of the swing and everts back to flat through heel strike, so that
roll and pitch rates never vanish together. Yaw turns and the contact point moves (a
lateral ``sway`` and a ``clearance`` bump included) during the swing only.

Position follows from the contact point: ``p_imu = P(s) - C_b^n(s) q(s)`` where ``P``
is the contact point on the floor (fixed during a rocker, flying during the swing) and
``q`` the vector from the IMU to it in the foot frame (``toe_arm`` during the toe
rocker, ``heel_arm`` during the heel rocker, blended in the air). Orientation is ZYX
Euler (yaw ``psi`` about z up, pitch ``theta`` about the foot's y (left) axis, roll
``phi`` about x (toe)), ``C_b^n = Rz(psi) Ry(theta) Rx(phi)`` from the foot's FLU frame
to ENU; positive pitch tilts the toe *down*. Every profile is a polynomial with
vanishing first and second derivatives at its ends (:mod:`.profiles`), and velocity,
acceleration, angular rate and angular acceleration are analytic, so an INS that
integrates the synthetic IMU reproduces the trajectory up to its own integration error.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..geometry import wrap_angles
from .profiles import bump, progress

#: Vertical style of a swing: how rise/fall and horizontal travel are timed.
LEVEL, UP, DOWN = 0, 1, 2

#: (a, b) of the contact point's horizontal progress, vertical progress and clearance
#: bump during the swing, per vertical style. a < b: early; a > b: late.
_H_PROFILE = {LEVEL: (3.0, 3.0), UP: (5.0, 3.0), DOWN: (3.0, 5.0)}
_V_PROFILE = {LEVEL: (4.0, 4.0), UP: (3.0, 5.0), DOWN: (5.0, 3.0)}
_CLEAR_PROFILE = {LEVEL: (3.0, 4.0), UP: (3.0, 4.0), DOWN: (4.0, 3.0)}
#: Pitch segments: heel-off -> maximum plantarflexion (slow heel rise, then fast),
#: -> maximum dorsiflexion (swing), -> foot-flat (the foot slap, fastest early).
_PITCH = ((5.0, 3.0), (3.0, 3.0), (3.0, 4.0))
#: Roll segments: heel-off -> inverted at toe-off (supination in push-off), held
#: through the swing until ``_ROLL_HOLD`` of it, -> everting through heel strike to
#: flat (so that roll and pitch rates do not vanish together).
_ROLL = ((5.0, 3.0), (3.0, 3.0), (3.0, 3.0))
_ROLL_HOLD = 0.6
_YAW = (4.0, 4.0)           # heading change over the swing
_ARM = (3.0, 3.0)           # contact point moves from the ball to the heel
_SWAY = (3.0, 3.0)
#: Maximum plantarflexion comes this fraction of the swing after toe-off. A foot
#: without rockers (it lifts off and lands flat) plantarflexes at a third of the swing
#: and is most toe-up at 70 % of it.
_PEAK_DELAY = 0.15
_FLAT_PEAKS = (1.0 / 3.0, 0.7)
#: The foot is most toe-up this fraction of the swing before heel strike: it already
#: turns toe-down when the heel lands (about 20 ms at normal walking).
_SLAP_LEAD = 0.05
#: Heel-pad and sole deformation after heel strike: duration [s], (a, b) of the bump,
#: and its direction: down and forward (the ground stops the heel's forward motion too;
#: the real recordings ring as much fore-aft as vertically).
IMPACT_S = 0.05
_IMPACT = (3.0, 3.0)
_IMPACT_DOWN, _IMPACT_FORWARD = 0.8, 0.6
#: Shortest swing (airborne) part of a moving phase, as a fraction of it.
_MIN_AIR = 0.2

#: Default contact points from the IMU in the foot frame [m]: an instep IMU 6 cm above
#: the floor, 10 cm ahead of the heel's contact point and 8 cm behind the ball of the
#: foot (metatarsal heads at about 70 % of a 27 cm foot from the heel).
HEEL_ARM = np.array([-0.10, 0.0, -0.06])
TOE_ARM = np.array([0.08, 0.0, -0.06])
#: A ground contact longer than this [s] (a stop) runs its ``phase`` through its first
#: and last half of this time only and holds mid-contact (0.5) in between.
LONG_CONTACT_S = 2.0


@dataclass
class StrideTable:
    """K moving phases of one foot, as arrays (SI units, ENU, radians).

    ``t0``/``t1`` (K,) heel-off and foot-flat [s], with ``t1[k] <= t0[k+1]``;
    ``p0``/``p1`` (K, 3) foot (IMU) position at the stance before and after;
    ``yaw0/yaw1``, ``pitch0/pitch1``, ``roll0/roll1`` (K,) stance orientation before and
    after; ``clearance`` (K,) [m] lift of the contact point at mid-swing; ``toe_off`` (K,) [rad]
    maximum toe-down pitch after toe-off; ``heel_strike`` (K,) [rad] toe-up pitch at
    heel strike; ``roll_amp`` (K,) [rad] inversion at toe-off and heel strike (signed);
    ``sway`` (K,) [m] lateral excursion to the left of travel; ``vstyle`` (K,)
    LEVEL/UP/DOWN; ``motion`` (K,) a label per swing (``walk``, ``stairs_up``,
    ``stairs_down``, ``stairs_down_backward``, ``crawl``, ``posture``...);
    ``impact`` (K,) [m] heel pad / sole give at heel strike (0: a soft landing);
    ``toe_rocker`` / ``heel_rocker`` (K,) [s] heel-off to toe-off and heel strike to
    foot-flat (None: 0, lift off and land flat); ``heel_arm`` / ``toe_arm`` (3,) [m]
    contact points from the IMU, foot frame; ``flex`` (K, 3) rotation vector (foot
    frame) in which the boot under the IMU turns over the ground contact that begins
    with this swing's landing, its length the turn relative to walking, zero for none
    (None: none; the angle of a unit vector is the mount's, :mod:`.mount`).
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
    toe_rocker: np.ndarray | None = None
    heel_rocker: np.ndarray | None = None
    heel_arm: np.ndarray = field(default_factory=lambda: HEEL_ARM.copy())
    toe_arm: np.ndarray = field(default_factory=lambda: TOE_ARM.copy())
    flex: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.t0)

    def check(self) -> None:
        """Raise ValueError if the table is not a valid sequence of swings."""
        if np.any(self.t1 <= self.t0):
            raise ValueError("every swing needs t1 > t0")
        if len(self) > 1 and np.any(self.t0[1:] < self.t1[:-1] - 1e-9):
            raise ValueError("swings overlap: t0[k+1] < t1[k]")
        for name in ("toe_rocker", "heel_rocker"):
            v = getattr(self, name)
            if v is not None and np.any((v < 0) | (v > (1 - _MIN_AIR) / 2 * (self.t1 - self.t0)
                                                   + 1e-9)):
                raise ValueError(f"{name} must be >= 0 and leave the swing at least "
                                 f"{_MIN_AIR:.0%} of the moving phase")
        if len(self) > 1:
            jump = np.abs(self.p0[1:] - self.p1[:-1]).max()
            if jump > 1e-9:
                raise ValueError(f"stance position jumps by {jump:.3g} m between swings")
            turn = np.abs(np.column_stack([wrap_angles(self.yaw0[1:] - self.yaw1[:-1]),
                                           self.pitch0[1:] - self.pitch1[:-1],
                                           self.roll0[1:] - self.roll1[:-1]])).max()
            if turn > 1e-9:
                raise ValueError(f"stance orientation jumps by {turn:.3g} rad between swings")

    def phases(self) -> tuple[np.ndarray, np.ndarray]:
        """(toe-off, heel-strike) phase of every moving phase, as fractions of it."""
        dur = self.t1 - self.t0
        zero = np.zeros(len(self))
        tr = zero if self.toe_rocker is None else self.toe_rocker / dur
        hr = zero if self.heel_rocker is None else self.heel_rocker / dur
        cap = (1.0 - _MIN_AIR) / 2
        return np.clip(tr, 0.0, cap), 1.0 - np.clip(hr, 0.0, cap)


@dataclass
class FootKinematics:
    """The true motion of the foot (IMU point) at N sample times.

    ``position``, ``velocity``, ``acceleration`` (N, 3) ENU [m, m/s, m/s^2];
    ``euler`` (N, 3) yaw, pitch, roll [rad] (yaw unwrapped); ``omega_body`` (N, 3)
    angular rate of the foot frame relative to the navigation frame, in the foot (FLU)
    frame [rad/s], ``angular_accel`` (N, 3) its time derivative [rad/s^2];
    ``stance`` (N,) True where the foot is flat and still; ``contact`` (N,) True where
    it touches the floor (stance and both rockers); ``phase`` (N,) in [0, 1]: on the
    floor, how far the current ground contact has progressed (0 at heel strike, 1 at
    toe-off), in the air how far the airborne swing has; ``flex`` (N, 3) the flex
    direction of the current (or, in the air, the last) ground contact (see
    :class:`StrideTable`); ``stride`` (N,) index of the current or last swing (-1
    before the first). ``phase`` and ``flex`` drive the boot's deformation in
    :mod:`.mount`.
    """

    t: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    euler: np.ndarray
    omega_body: np.ndarray
    stance: np.ndarray
    stride: np.ndarray
    angular_accel: np.ndarray | None = None
    contact: np.ndarray | None = None
    phase: np.ndarray | None = None
    flex: np.ndarray | None = None

    @classmethod
    def at_rest(cls, t: np.ndarray, position: np.ndarray, euler: np.ndarray
                ) -> "FootKinematics":
        """A foot standing still at ``position`` (3,) with ``euler`` (3,) for all ``t``."""
        n = len(t)
        z3 = np.zeros((n, 3))
        return cls(t=t, position=np.repeat(np.asarray(position, float)[None], n, 0),
                   velocity=z3, acceleration=z3.copy(),
                   euler=np.repeat(np.asarray(euler, float)[None], n, 0),
                   omega_body=z3.copy(), stance=np.ones(n, bool), stride=np.full(n, -1),
                   angular_accel=z3.copy(), contact=np.ones(n, bool), phase=np.full(n, 0.5),
                   flex=z3.copy())



def body_rates(euler: np.ndarray, euler_rate: np.ndarray) -> np.ndarray:
    """Body angular rate (FLU) from ZYX Euler angles and their rates [rad/s]."""
    _, th, ph = euler.T
    dps, dth, dph = euler_rate.T
    sth, cth = np.sin(th), np.cos(th)
    sph, cph = np.sin(ph), np.cos(ph)
    return np.column_stack([dph - dps * sth,
                            dth * cph + dps * cth * sph,
                            -dth * sph + dps * cth * cph])


def body_accels(euler: np.ndarray, euler_rate: np.ndarray, euler_acc: np.ndarray
                ) -> np.ndarray:
    """Time derivative of :func:`body_rates` [rad/s^2] (body frame)."""
    _, th, ph = euler.T
    dps, dth, dph = euler_rate.T
    aps, ath, aph = euler_acc.T
    sth, cth = np.sin(th), np.cos(th)
    sph, cph = np.sin(ph), np.cos(ph)
    return np.column_stack([
        aph - aps * sth - dps * dth * cth,
        ath * cph - dth * dph * sph + aps * cth * sph - dps * dth * sth * sph
        + dps * dph * cth * cph,
        -ath * sph - dth * dph * cph + aps * cth * cph - dps * dth * sth * cph
        - dps * dph * cth * sph])


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


def _knotted(s: np.ndarray, k1: np.ndarray, k2: np.ndarray, values: tuple, inv: np.ndarray,
             segments: tuple) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A quantity through four knots at phases 0, k1, k2, 1 with values ``values`` (each
    (N,)), C2 progress segments with (a, b) ``segments`` between them; (value, d/dt,
    d2/dt2) with ``inv`` = 1 / duration of the moving phase [1/s]."""
    seg = np.where(s < k1, 0, np.where(s < k2, 1, 2))
    lo = np.choose(seg, [np.zeros_like(s), k1, k2])
    hi = np.choose(seg, [k1, k2, np.ones_like(s)])
    va = np.choose(seg, values[:3])
    vb = np.choose(seg, values[1:])
    a = np.array([p[0] for p in segments])[seg]
    b = np.array([p[1] for p in segments])[seg]
    span = hi - lo
    f, d1, d2 = progress((s - lo) / span, a, b)
    rate = inv / span
    dv = vb - va
    return va + dv * f, dv * d1 * rate, dv * d2 * rate * rate


def _rotate(c: np.ndarray, v: np.ndarray) -> np.ndarray:
    """C (N, 3, 3) times v (N, 3)."""
    return np.einsum("nij,nj->ni", c, v)


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

    s_to_k, s_hs_k = table.phases()
    s_to, s_hs = s_to_k[kc], s_hs_k[kc]
    air = s_hs - s_to
    s_pk = s_to + air * np.where(s_to > 0.0, _PEAK_DELAY, _FLAT_PEAKS[0])
    s_up = np.where(s_hs < 1.0, s_hs - _SLAP_LEAD * air, s_to + air * _FLAT_PEAKS[1])
    u_air = np.clip((s - s_to) / air, 0.0, 1.0)
    inv_air = inv / air

    # -- orientation ---------------------------------------------------------------
    dyaw = wrap_angles(table.yaw1 - table.yaw0)[kc]
    # Yaw is unwrapped along the table so that rates are smooth across +-pi.
    yaw_start = table.yaw0[0] + np.concatenate([[0.0], np.cumsum(wrap_angles(table.yaw1 - table.yaw0))])
    uy, uy1, uy2 = progress(u_air, *_YAW)
    p0_, p1_ = table.pitch0[kc], table.pitch1[kc]
    r0_, r1_ = table.roll0[kc], table.roll1[kc]
    a_to, a_hs, a_r = table.toe_off[kc], table.heel_strike[kc], table.roll_amp[kc]
    pitch = _knotted(s, s_pk, s_up, (p0_, p0_ + a_to, p1_ - a_hs, p1_), inv, _PITCH)
    roll = _knotted(s, np.maximum(s_to, 0.5 * s_pk), s_to + _ROLL_HOLD * air,
                    (r0_, r0_ + a_r, r1_ + a_r, r1_), inv, _ROLL)
    euler = np.column_stack([yaw_start[kc] + dyaw * uy, pitch[0], roll[0]])
    euler_rate = np.column_stack([dyaw * uy1 * inv_air, pitch[1], roll[1]])
    euler_acc = np.column_stack([dyaw * uy2 * inv_air ** 2, pitch[2], roll[2]])
    still = ~swing
    euler_rate[still] = 0.0
    euler_acc[still] = 0.0
    c_bn = euler_matrix(euler)
    omega = body_rates(euler, euler_rate)
    omega_dot = body_accels(euler, euler_rate, euler_acc)

    # -- the contact point and the IMU ---------------------------------------------
    toe, heel = np.asarray(table.toe_arm, float), np.asarray(table.heel_arm, float)
    ua, ua1, ua2 = progress(u_air, *_ARM)
    q = toe + (heel - toe) * ua[:, None]
    qd = (heel - toe) * (ua1 * inv_air)[:, None]
    qdd = (heel - toe) * (ua2 * inv_air ** 2)[:, None]
    e0 = np.column_stack([table.yaw0[kc], p0_, r0_])
    e1 = np.column_stack([table.yaw1[kc], p1_, r1_])
    c0, c1 = euler_matrix(e0), euler_matrix(e1)
    big_p0 = table.p0[kc] + c0 @ toe
    big_p1 = table.p1[kc] + c1 @ heel
    d = big_p1 - big_p0

    vstyle = table.vstyle[kc]
    prof = lambda tab, i: np.array([tab[v][i] for v in (LEVEL, UP, DOWN)])[vstyle]  # noqa: E731
    uh, uh1, uh2 = progress(u_air, prof(_H_PROFILE, 0), prof(_H_PROFILE, 1))
    uv, uv1, uv2 = progress(u_air, prof(_V_PROFILE, 0), prof(_V_PROFILE, 1))
    cz, cz1, cz2 = bump(u_air, prof(_CLEAR_PROFILE, 0), prof(_CLEAR_PROFILE, 1))
    sw, sw1, sw2 = bump(u_air, *_SWAY)
    # Lateral (left) unit vector of the travel direction; for in-place swings use the
    # mean foot heading instead.
    dd = table.p1[kc] - table.p0[kc]
    horiz = np.hypot(dd[:, 0], dd[:, 1])
    travel = np.where(horiz > 1e-6, np.arctan2(dd[:, 1], dd[:, 0]),
                      table.yaw0[kc] + 0.5 * dyaw)
    left = np.column_stack([-np.sin(travel), np.cos(travel)])
    sway = table.sway[kc][:, None] * left

    big = np.empty((n, 3))
    big_d = np.empty((n, 3))
    big_dd = np.empty((n, 3))
    big[:, :2] = big_p0[:, :2] + d[:, :2] * uh[:, None] + sway * sw[:, None]
    big_d[:, :2] = (d[:, :2] * uh1[:, None] + sway * sw1[:, None]) * inv_air[:, None]
    big_dd[:, :2] = (d[:, :2] * uh2[:, None] + sway * sw2[:, None]) * (inv_air ** 2)[:, None]
    h = table.clearance[kc]
    big[:, 2] = big_p0[:, 2] + d[:, 2] * uv + h * cz
    big_d[:, 2] = (d[:, 2] * uv1 + h * cz1) * inv_air
    big_dd[:, 2] = (d[:, 2] * uv2 + h * cz2) * inv_air ** 2
    if table.impact is not None:
        w = np.minimum(IMPACT_S * inv, 1.0 - s_to)           # impact window [phase]
        start = np.minimum(s_hs, 1.0 - w)
        im, im1, im2 = bump((s - start) / w, *_IMPACT)          # zero outside the window
        yaw1 = table.yaw1[kc]
        direction = table.impact[kc][:, None] * np.column_stack(
            [_IMPACT_FORWARD * np.cos(yaw1), _IMPACT_FORWARD * np.sin(yaw1),
             np.full(n, -_IMPACT_DOWN)])
        big += direction * im[:, None]
        big_d += direction * (im1 * inv / w)[:, None]
        big_dd += direction * (im2 * (inv / w) ** 2)[:, None]

    pos = big - _rotate(c_bn, q)
    vel = big_d - _rotate(c_bn, np.cross(omega, q) + qd)
    acc = big_dd - _rotate(c_bn, np.cross(omega_dot, q) + np.cross(omega, np.cross(omega, q))
                           + 2.0 * np.cross(omega, qd) + qdd)
    vel[still] = 0.0
    acc[still] = 0.0
    omega[still] = 0.0
    omega_dot[still] = 0.0
    airborne = ~still & (s > s_to) & (s < s_hs)
    phase, flex = _contact_phase(table, t, k, kc, s, s_to_k, s_hs_k, airborne)
    return FootKinematics(t=t, position=pos, velocity=vel, acceleration=acc, euler=euler,
                          omega_body=omega, stance=still, stride=k, angular_accel=omega_dot,
                          contact=~airborne, phase=np.where(airborne, u_air, phase), flex=flex)


def _contact_phase(table: StrideTable, t: np.ndarray, k: np.ndarray, kc: np.ndarray,
                   s: np.ndarray, s_to: np.ndarray, s_hs: np.ndarray, airborne: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Phase of the current ground contact (see :class:`FootKinematics`; meaningless in
    the air) and the flex direction (N, 3) of that contact (in the air: the last one)."""
    K = len(table)
    dur = table.t1 - table.t0
    t_to = table.t0 + s_to * dur                       # toe-off of each swing
    t_hs = table.t0 + s_hs * dur                       # heel strike of each swing
    flex_k = np.zeros((K, 3)) if table.flex is None else np.asarray(table.flex, float)
    # the contact a sample belongs to ends with the toe-off of swing `nxt` and began
    # with the heel strike of swing nxt - 1 (-1: the start of the recording)
    landed = (k >= 0) & (s >= s_hs[kc])                # heel rocker or stance after it
    nxt = np.where(landed, k + 1, np.maximum(k, 0))
    prev = nxt - 1
    begin = np.where(prev >= 0, t_hs[np.clip(prev, 0, K - 1)], -np.inf)
    end = np.where(nxt < K, t_to[np.clip(nxt, 0, K - 1)], np.inf)
    length = end - begin
    short = length <= LONG_CONTACT_S
    with np.errstate(invalid="ignore"):
        phase = np.where(short, (t - begin) / np.where(short, length, 1.0),
                         np.clip((t - begin) / LONG_CONTACT_S, 0.0, 0.5)
                         + np.clip((t - (end - 0.5 * LONG_CONTACT_S)) / LONG_CONTACT_S, 0.0, 0.5))
    phase = np.clip(np.nan_to_num(phase, nan=0.5), 0.0, 1.0)
    source = np.where(airborne, k - 1, prev)
    flex = np.where((source >= 0)[:, None], flex_k[np.clip(source, 0, K - 1)], 0.0)
    return phase, flex
