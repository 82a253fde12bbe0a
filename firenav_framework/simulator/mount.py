"""How the IMU moves on the boot: a compliant mount between the foot and the IMU.

The foot of :mod:`.gait` is rigid and truly still in flat stance. The IMU is strapped
to the boot's upper, which is not rigid, so the IMU moves relative to the foot by a
few millimetres and degrees (foot frame, FLU):

* **impact ringing**: the IMU on its strap is a damped spring-mass system (natural
  frequency ``natural_hz``, damping ratio ``damping``), base-excited by the foot's
  specific force (translation ``u``) and angular acceleration (rotation ``rho``); a
  sideways or fore-aft specific force also rocks it on the strap
  (``rocking_deg_per_g``). The heel-strike transient makes it ring;
* **boot flex**: over one ground contact the upper under the IMU turns relative to the
  still sole (the shank rolls forward over the foot and rotates outwards, the rearfoot
  everts), by ``flex_deg`` along the stride table's per-contact direction, about the
  sole point under the IMU, and springs back in the swing;
* **sole shear**: the braking and then propulsive ground force shifts the upper over
  the outsole backward, then forward, by up to ``shear_mm``;
* **pivot slide**: a foot that turns on the floor (a tight curve: the loaded shoe
  pivots on the ball of the foot or the heel) carries the IMU a few centimetres across
  the floor while it is nearly still; modelled as a slow horizontal shift per ground
  contact, of random direction and ``pivot_slide_mm`` rms per radian the foot turned
  since the contact before, growing over the contact like the flex and springing back
  in the swing (the turn itself stays in the swing);
* **postural sway**: a standing person sways; the IMU sees it as a slow random
  rotation of ``sway_dps`` rms rate (band 0.2-2 Hz).

They set the equilibrium of the mount; the mount follows it through its second-order
dynamics, per axis (``w = 2 pi natural_hz``, ``z = damping``)::

    u''   + 2 z w u'   + w^2 u   = w^2 u_eq   - f_b       u_eq: flex about the sole, shear
    rho'' + 2 z w rho' + w^2 rho = w^2 rho_eq - dw_b/dt   rho_eq: rocking + flex + sway

with ``f_b`` the foot's specific force and ``w_b`` its angular rate (foot frame). Both
are discretised exactly for a drive linear between samples (first-order hold, so that
the samples of ``u''`` belong to one smooth motion) and run as IIR filters over whole
recordings (no per-sample Python). :func:`imu_kinematics` turns foot and mount motion
into the IMU's own: position ``p + C u``, orientation ``C exp(rho)``. Parameter values
and where they come from: :class:`MountConfig`, ``docs/scenarios.md``.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from pydantic import ConfigDict, Field

from scipy.linalg import expm
from scipy.signal import butter, lfilter, sosfilt
from scipy.spatial.transform import Rotation

from ..field_docs import DescribedModel
from .gait import FootKinematics, StrideTable, euler_matrix
from .profiles import progress

G0 = 9.80665


class MountConfig(DescribedModel):
    """The IMU's attachment to the boot (``sensors.imu.mount`` of a scenario).

    Defaults from the real foot-IMU recordings in ``../shared/data`` (MicroStrain
    3DM-GX5 strapped on the shoe; ``benchmarks/bench_sim_realism.py`` measures them):
    after heel strike the signals ring at 15-20 Hz and die out within two or three
    periods (damping ratio about 0.2), 35-45 deg/s rms above 10 Hz in the gyro
    (``rocking_deg_per_g``); in mid-stance the IMU of the indoor walks still turns at
    8-14 deg/s at normal walking (``flex_deg``; the VICON trials' mount about half of
    that); VICON shows the IMU moving about 5 mm while it turns at under 20 deg/s
    (``shear_mm`` with the flex); a standing wearer's IMU turns at 0.2-0.6 deg/s rms
    below 2 Hz (``sway_dps``).
    """

    model_config = ConfigDict(extra="forbid", frozen=True)

    natural_hz: float = Field(18.0, gt=2, le=200)
    """natural frequency of the IMU on its strap [Hz]"""
    damping: float = Field(0.2, gt=0, le=2)
    """damping ratio of the mount"""
    rocking_deg_per_g: float = Field(1.0, ge=0, le=10)
    """static tilt of the IMU on its strap per g of sideways / fore-aft specific force [deg/g]"""
    flex_deg: float = Field(12.0, ge=0, le=20)
    """rotation of the upper under the IMU relative to the sole over one ground contact [deg]"""
    shear_mm: float = Field(2.5, ge=0, le=20)
    """fore-aft shift of the upper over the outsole under the braking and propulsive ground force
    (peak) [mm]"""
    pivot_slide_mm: float = Field(0.0, ge=0, le=100)
    """rms horizontal shift of the IMU over one ground contact per radian the foot turned since the
    last contact (the shoe pivoting on the floor) [mm/rad]"""
    sway_dps: float = Field(0.3, ge=0, le=5)
    """rms angular rate of postural sway seen by the IMU [deg/s], 0.2-2 Hz"""
    rock_deg: float = Field(4.2, ge=0, le=20)
    """on all fours: how far the shoe, lying on its top, rocks over one contact as the weight
    shifts [deg] (the real crawl trials; not the boot's flex, which needs the ankle)"""


@dataclass
class MountMotion:
    """The IMU relative to the foot, per sample (foot frame, FLU).

    ``u``, ``u_dot``, ``u_ddot`` (N, 3) displacement [m, m/s, m/s^2]; ``rho``,
    ``rho_dot`` (N, 3) rotation vector of the IMU frame relative to the foot frame
    [rad, rad/s].
    """

    u: np.ndarray
    u_dot: np.ndarray
    u_ddot: np.ndarray
    rho: np.ndarray
    rho_dot: np.ndarray


def rocking_on_all_fours(table: StrideTable, config: MountConfig) -> StrideTable:
    """``table`` with the contacts that follow crawl swings turning by ``config.rock_deg``
    instead of the boot's ``flex_deg`` (their flex vectors rescaled)."""
    if table.flex is None or config.flex_deg == 0:
        return table
    crawl = np.array([m == "crawl" for m in table.motion], bool)
    if not crawl.any():
        return table
    flex = np.array(table.flex, float)
    flex[crawl] *= config.rock_deg / config.flex_deg
    return dataclasses.replace(table, flex=flex)


def _oscillator(drive: np.ndarray, fs: float, w: float, zeta: float
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Response (y, y', y'') of ``y'' + 2 zeta w y' + w^2 y = drive`` (N, 3), starting
    at rest in equilibrium with the first sample.

    The drive is taken as linear between samples (first-order hold), which makes the
    samples of y'' those of a continuous function: integrating them reproduces y with
    the integrator's own O(dt^2) error.
    """
    a = np.array([[0.0, 1.0], [-w * w, -2.0 * zeta * w]])
    n = 2
    m = np.zeros((4, 4))                   # [[A, B, 0], [0, 0, 1/T], [0, 0, 0]] * T
    m[:n, :n] = a / fs
    m[:n, n] = [0.0, 1.0 / fs]
    m[n, n + 1] = 1.0
    e = expm(m)
    phi, g1, g2 = e[:n, :n], e[:n, n], e[:n, n + 1]
    c, d = g1 - g2, g2                     # x_{k+1} = Phi x_k + c r_k + d r_{k+1}
    den = np.array([1.0, -np.trace(phi), np.linalg.det(phi)])
    num_y = np.array([d[0], c[0] - phi[1, 1] * d[0] + phi[0, 1] * d[1],
                      -phi[1, 1] * c[0] + phi[0, 1] * c[1]])
    num_v = np.array([d[1], c[1] - phi[0, 0] * d[1] + phi[1, 0] * d[0],
                      phi[1, 0] * c[0] - phi[0, 0] * c[1]])
    r0 = drive[:1]
    r = drive - r0
    y = lfilter(num_y, den, r, axis=0) + r0 / (w * w)
    v = lfilter(num_v, den, r, axis=0)
    return y, v, drive - 2.0 * zeta * w * v - w * w * y


#: The boot flexes fastest after heel strike and before toe-off and least in
#: mid-stance: flex rate ~ 1 + FLEX_ENDS cos(2 pi phase) over a ground contact.
FLEX_ENDS = 0.5


def boot_deformation(kin: FootKinematics) -> tuple[np.ndarray, np.ndarray]:
    """(flex, shear) per sample, each of unit amplitude.

    Flex grows from 0 at heel strike to 1 at toe-off (rate ~ 1 + FLEX_ENDS cos(2 pi
    phase)) and springs back to 0 over the swing. Shear follows the fore-aft ground
    force: braking after heel strike (backward), propulsion before toe-off (forward),
    ``-sin(2 pi phase)``, none in the air.
    """
    u = kin.phase
    on = kin.contact
    ramp = u + FLEX_ENDS * np.sin(2.0 * np.pi * u) / (2.0 * np.pi)
    flex = np.where(on, ramp, 1.0 - progress(u, 3.0, 3.0)[0])
    shear = np.where(on, -np.sin(2.0 * np.pi * u), 0.0)
    return flex, shear


def specific_force_body(kin: FootKinematics, gravity: float) -> np.ndarray:
    """The foot's specific force in the foot frame (N, 3) [m/s^2] (no Earth rate)."""
    f_n = kin.acceleration.copy()
    f_n[:, 2] += gravity
    return np.einsum("nji,nj->ni", euler_matrix(kin.euler), f_n)


def sway_angles(n: int, fs: float, rms_dps: float, rng: np.random.Generator) -> np.ndarray:
    """(n, 3) postural sway rotation [rad]: band-limited (0.2-2 Hz) noise whose rate has
    ``rms_dps`` rms per axis."""
    if rms_dps == 0.0 or n < 2:
        return np.zeros((n, 3))
    sos = butter(2, [0.2, 2.0], btype="bandpass", fs=fs, output="sos")
    warm = int(10 * fs)                      # let the filter forget its start
    x = sosfilt(sos, rng.standard_normal((n + warm, 3)), axis=0)[warm:]
    rate = np.gradient(x, 1.0 / fs, axis=0)
    return x * (np.radians(rms_dps) / np.sqrt(np.mean(rate ** 2, axis=0)))


def contact_index(contact: np.ndarray) -> np.ndarray:
    """(N,) index of the current ground contact (in the air: the last one), from 0 at
    the first; -1 before it."""
    on = np.asarray(contact, bool)
    starts = on & ~np.concatenate([[False], on[:-1]])
    return np.cumsum(starts) - 1


def pivot_slides(kin: FootKinematics, config: MountConfig, rng: np.random.Generator
                 ) -> np.ndarray:
    """(N, 3) pivot slide of every sample at full size (foot frame) [m]: per contact a
    random horizontal vector of ``pivot_slide_mm`` rms (per axis / sqrt 2) per radian of
    the yaw turned since the contact before."""
    cid = contact_index(kin.contact)
    n_contacts = int(cid.max()) + 1 if len(cid) else 0
    out = np.zeros((len(cid), 3))
    if config.pivot_slide_mm == 0.0 or n_contacts < 2:
        return out
    first = np.searchsorted(cid, np.arange(n_contacts))
    turn = np.abs(np.diff(kin.euler[first, 0], prepend=kin.euler[first[0], 0]))
    slide = np.zeros((n_contacts, 3))
    slide[:, :2] = (rng.standard_normal((n_contacts, 2)) / np.sqrt(2.0)
                    * (config.pivot_slide_mm / 1000.0 * turn)[:, None])
    inside = cid >= 0
    out[inside] = slide[cid[inside]]
    return out


def mount_motion(kin: FootKinematics, fs: float, config: MountConfig, pivot: np.ndarray,
                 rng: np.random.Generator, gravity: float = 9.81) -> MountMotion:
    """Motion of the IMU on its mount for foot motion ``kin`` sampled uniformly at ``fs``.

    ``pivot`` (3,) [m]: the sole point under the IMU, from the IMU, foot frame (the
    upper flexes about it).
    """
    missing = [k for k in ("angular_accel", "contact", "phase", "flex") if getattr(kin, k) is None]
    if missing:
        raise ValueError(f"foot kinematics without {', '.join(missing)}: make them with "
                         "foot_kinematics() or FootKinematics.at_rest()")
    w = 2.0 * np.pi * config.natural_hz
    f_b = specific_force_body(kin, gravity)
    flex_amount, shear = boot_deformation(kin)
    flex = kin.flex * (np.radians(config.flex_deg) * flex_amount)[:, None]
    rock = np.radians(config.rocking_deg_per_g) / G0 * np.cross([0.0, 0.0, 1.0], f_b)
    rho_eq = rock + flex + sway_angles(len(f_b), fs, config.sway_dps, rng)
    omega_dot = kin.angular_accel
    rho, rho_dot, _ = _oscillator(w * w * rho_eq - omega_dot, fs, w, config.damping)
    lever = -np.asarray(pivot, float)
    u_eq = Rotation.from_rotvec(flex).apply(lever) - lever
    u_eq[:, 0] += config.shear_mm / 1000.0 * shear
    u_eq += pivot_slides(kin, config, rng) * flex_amount[:, None]
    u, u_dot, u_ddot = _oscillator(w * w * u_eq - f_b, fs, w, config.damping)
    return MountMotion(u=u, u_dot=u_dot, u_ddot=u_ddot, rho=rho, rho_dot=rho_dot)


@dataclass
class ImuKinematics:
    """The IMU's own motion: ``position``, ``velocity``, ``acceleration`` (N, 3) ENU;
    ``c_bn`` (N, 3, 3) IMU frame to ENU; ``omega_body`` (N, 3) its angular rate relative
    to the navigation frame, IMU frame [rad/s]."""

    position: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    c_bn: np.ndarray
    omega_body: np.ndarray


def imu_kinematics(kin: FootKinematics, mount: MountMotion | None = None) -> ImuKinematics:
    """The IMU's motion: the foot's, plus the mount's relative motion if given.

    Exact rigid-body kinematics of the point ``p + C u`` (with the rotating-frame
    terms) and of the orientation ``C exp(rho)``.
    """
    c_bn = euler_matrix(kin.euler)
    if mount is None:
        return ImuKinematics(kin.position, kin.velocity, kin.acceleration, c_bn, kin.omega_body)
    w = kin.omega_body
    wd = kin.angular_accel if kin.angular_accel is not None else np.zeros_like(w)
    u, ud, udd = mount.u, mount.u_dot, mount.u_ddot
    rot = lambda v: np.einsum("nij,nj->ni", c_bn, v)  # noqa: E731
    pos = kin.position + rot(u)
    vel = kin.velocity + rot(ud + np.cross(w, u))
    acc = kin.acceleration + rot(udd + 2.0 * np.cross(w, ud) + np.cross(wd, u)
                                 + np.cross(w, np.cross(w, u)))
    r = Rotation.from_rotvec(mount.rho).as_matrix()          # IMU -> foot
    omega = np.einsum("nji,nj->ni", r, w) + _right_jacobian_times(mount.rho, mount.rho_dot)
    return ImuKinematics(pos, vel, acc, c_bn @ r, omega)


def _right_jacobian_times(rho: np.ndarray, rho_dot: np.ndarray) -> np.ndarray:
    """Angular rate (rotated frame) of the rotation ``exp(rho)``: ``J_r(rho) rho'`` with
    the right Jacobian of SO(3), ``I - (1 - cos a)/a^2 [rho]x + (a - sin a)/a^3 [rho]x^2``."""
    a2 = np.sum(rho * rho, axis=1)
    a = np.sqrt(a2)
    small = a < 1e-4
    safe = np.where(small, 1.0, a)
    c1 = np.where(small, 0.5 - a2 / 24.0, (1.0 - np.cos(safe)) / safe ** 2)
    c2 = np.where(small, 1.0 / 6.0 - a2 / 120.0, (safe - np.sin(safe)) / safe ** 3)
    x = np.cross(rho, rho_dot)
    return rho_dot - c1[:, None] * x + c2[:, None] * np.cross(rho, x)
