"""Synthetic foot-IMU recordings with exact truth, for the INS tests.

A walk is a list of :class:`Stride`: the foot rests (flat, or tilted for crawling),
then swings to its next footprint along minimum-jerk profiles (position, yaw) with a
clearance bump and a toe-off pitch, all polynomials in the swing phase s = (t - t0)/T
whose first and second derivatives vanish at both ends. Specific force and angular
rate in the FLU body frame follow analytically:

    f_b = R^T (a_n + [0, 0, g]),   w_b = Ry(pitch)^T [0, 0, yaw'] + [0, pitch', 0],

with ``R = Rz(yaw) Ry(pitch)`` (body -> ENU).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.polynomial import Polynomial as Poly

MIN_JERK = Poly([0, 0, 0, 10, -15, 6])                 # 0 -> 1, flat ends
BUMP = Poly([0, 0, 0, 64, -192, 192, -64])             # 64 s^3 (1 - s)^3, peak 1 at s = 1/2
_TOE = Poly([0, 0, 1, -4, 5, -2])                        # s^2 (1-s)^2 (1-2s)
TOE = _TOE * (1.0 / np.abs(_TOE(np.linspace(0, 1, 2001))).max())   # scaled to +-1


@dataclass(frozen=True)
class Stride:
    """One rest + swing of the instrumented foot (SI units, ENU)."""

    step: tuple[float, float, float]   # footprint displacement [m]
    turn: float = 0.0                  # yaw change over the swing [rad]
    stance: float = 0.5                # rest before the swing [s]
    swing: float = 0.7                 # [s]
    clearance: float = 0.08            # [m]
    toe_pitch: float = 0.5             # pitch amplitude in the swing [rad]
    rest_pitch: float = 0.0            # pitch of the foot in the rest before the swing [rad]
                                       # (crawling: ~1.4); the previous swing turns into it


@dataclass
class Recording:
    t: np.ndarray            # (N,) [s]
    accel: np.ndarray        # (N, 3) FLU [m/s^2]
    gyro: np.ndarray         # (N, 3) FLU [rad/s]
    position: np.ndarray     # (N, 3) ENU [m]
    yaw: np.ndarray          # (N,) [rad]
    footprints: np.ndarray   # (K+1, 3) rest positions, first = start
    headings: np.ndarray     # (K+1,) rest yaws
    stance_onsets: np.ndarray  # (K,) [s] time each swing ends


def _rot_y(a: np.ndarray) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    r = np.zeros((len(a), 3, 3))
    r[:, 0, 0], r[:, 0, 2], r[:, 1, 1], r[:, 2, 0], r[:, 2, 2] = c, s, 1.0, -s, c
    return r


def _rot_z(a: np.ndarray) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    r = np.zeros((len(a), 3, 3))
    r[:, 0, 0], r[:, 0, 1], r[:, 1, 0], r[:, 1, 1], r[:, 2, 2] = c, -s, s, c, 1.0
    return r


def walk(strides: list[Stride], *, rate: float = 200.0, start_rest: float = 1.0,
         end_rest: float = 1.0, yaw0: float = 0.0, g: float = 9.81) -> Recording:
    """Noise-free recording of ``strides`` (first rest ``start_rest`` s, last ``end_rest`` s)."""
    dt = 1.0 / rate
    pieces = []     # (t, pos, vel, acc, yaw, yaw', yaw'', pitch, pitch', pitch'')
    p = np.zeros(3)
    yaw = yaw0
    t0 = 0.0
    feet, heads, onsets = [p.copy()], [yaw], []
    plan = [(start_rest, s) for s in strides[:1]] + [(s.stance, s) for s in strides[1:]]
    next_pitch = [s.rest_pitch for s in strides[1:]] + [strides[-1].rest_pitch if strides else 0.0]
    for (rest, s), pitch_after in zip(plan, next_pitch):
        n = int(round(rest * rate))
        tt = t0 + dt * np.arange(n)
        z = np.zeros(n)
        pieces.append((tt, np.tile(p, (n, 1)), np.zeros((n, 3)), np.zeros((n, 3)),
                       np.full(n, yaw), z, z, np.full(n, s.rest_pitch), z, z))
        t0 += rest
        n = int(round(s.swing * rate))
        sp = np.arange(n) / n
        tt = t0 + dt * np.arange(n)
        T = s.swing
        d = np.asarray(s.step, float)
        m, m1, m2 = MIN_JERK(sp), MIN_JERK.deriv(1)(sp) / T, MIN_JERK.deriv(2)(sp) / T**2
        b, b1, b2 = BUMP(sp), BUMP.deriv(1)(sp) / T, BUMP.deriv(2)(sp) / T**2
        pos = p + np.outer(m, d)
        pos[:, 2] += s.clearance * b
        vel = np.outer(m1, d)
        vel[:, 2] += s.clearance * b1
        acc = np.outer(m2, d)
        acc[:, 2] += s.clearance * b2
        c, c1, c2 = TOE(sp), TOE.deriv(1)(sp) / T, TOE.deriv(2)(sp) / T**2
        # pitch: from this rest's pitch to the next one's, plus the toe-off motion
        dp = pitch_after - s.rest_pitch
        pieces.append((tt, pos, vel, acc, yaw + s.turn * m, s.turn * m1, s.turn * m2,
                       s.rest_pitch + dp * m + s.toe_pitch * c, dp * m1 + s.toe_pitch * c1,
                       dp * m2 + s.toe_pitch * c2))
        t0 += T
        p = p + d
        yaw += s.turn
        feet.append(p.copy())
        heads.append(yaw)
        onsets.append(t0)
    n = int(round(end_rest * rate))
    z = np.zeros(n)
    last_pitch = strides[-1].rest_pitch if strides else 0.0
    pieces.append((t0 + dt * np.arange(n), np.tile(p, (n, 1)), np.zeros((n, 3)),
                   np.zeros((n, 3)), np.full(n, yaw), z, z, np.full(n, last_pitch), z, z))
    t, pos, vel, acc, psi, psi1, _, th, th1, _ = (np.concatenate(x) for x in zip(*pieces))
    R = _rot_z(psi) @ _rot_y(th)
    f_nav = acc + np.array([0.0, 0.0, g])
    accel = np.einsum("nji,nj->ni", R, f_nav)
    yaw_rate = np.zeros((len(t), 3))
    yaw_rate[:, 2] = psi1
    gyro = np.einsum("nji,nj->ni", _rot_y(th), yaw_rate)
    gyro[:, 1] += th1
    return Recording(t=t, accel=accel, gyro=gyro, position=pos, yaw=psi,
                     footprints=np.array(feet), headings=np.array(heads),
                     stance_onsets=np.array(onsets))


def add_noise(rec: Recording, rng: np.random.Generator, *, accel_density: float = 9.8e-4,
              gyro_density: float = 8.7e-5, accel_bias=(0.0, 0.0, 0.0),
              gyro_bias=(0.0, 0.0, 0.0)) -> Recording:
    """White noise at the given densities (per sample sigma = density * sqrt(rate)) + biases."""
    rate = 1.0 / float(np.median(np.diff(rec.t)))
    n = len(rec.t)
    accel = rec.accel + np.asarray(accel_bias) + rng.normal(0, accel_density * math.sqrt(rate), (n, 3))
    gyro = rec.gyro + np.asarray(gyro_bias) + rng.normal(0, gyro_density * math.sqrt(rate), (n, 3))
    return Recording(**{**rec.__dict__, "accel": accel, "gyro": gyro})


def still(duration: float, *, rate: float = 200.0, roll: float = 0.0, pitch: float = 0.0,
          g: float = 9.81) -> Recording:
    """A resting IMU with the given roll and pitch (yaw 0)."""
    n = int(round(duration * rate))
    t = np.arange(n) / rate
    cr, sr, cp, sp = math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch)
    f = g * np.array([-sp, cp * sr, cp * cr])   # R^T [0, 0, g] for R = Ry(pitch) Rx(roll)
    return Recording(t=t, accel=np.tile(f, (n, 1)), gyro=np.zeros((n, 3)),
                     position=np.zeros((n, 3)), yaw=np.zeros(n), footprints=np.zeros((1, 3)),
                     headings=np.zeros(1), stance_onsets=np.zeros(0))
