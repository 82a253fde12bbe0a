"""Strapdown mechanisation and error-state Kalman filter with zero-velocity updates.

The sequential per-sample part of the ZUPT-aided INS (Nilsson et al., "Foot-mounted
inertial navigation made easy", the INS of search-pattern-particle-filter §IV-A and
orca-map-matching §2.1 / Algorithm 1), as numba kernels over plain arrays:

* nominal state ``x`` (16,): position p [m] and velocity v [m/s] in the INS ENU frame,
  attitude quaternion q (FLU body -> ENU), accelerometer bias ba [m/s^2] and gyro bias
  bg [rad/s] (both body frame);
* error state (19,): dp, dv, dtheta (nav-frame attitude error) — the nine states of
  orca-map-matching eq. (1) — then a *clone* of (dp, dyaw) taken at the last step
  event (stochastic cloning: gives the covariance of the step increment), then dba,
  dbg. Without bias states the filter runs on the first 13 only.

Transition (orca-map-matching eq. 1-2, with bias columns): ``F = I + dt*A`` with
``A_pv = I``, ``A_vθ = -[R f]x``, ``A_v,ba = -R``, ``A_θ,bg = -R``; discrete process
noise from noise densities, ``Q = sigma^2 * dt`` per axis (isotropic, so independent of
R). Zero-velocity pseudo-measurement ``0 = v + n``, ``n ~ N(0, sigma_zupt^2 I)``.

Events: a step event ``step_settle`` into each stance (at the stance's last sample when
it is shorter), when the stance's zero-velocity updates have settled its position, with
the position correction of the onset (``E_CORR``, for the retrospective correction of
the swing); a still event every ``still_period`` while the foot rests. At each stance
onset the level-floor update (:func:`_level_floor`) may pull the height to the floor's.

The filter state lives in arrays that the caller keeps between blocks, so processing a
recording block by block gives bit-identical results to processing it whole.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from .rotation import level_quat, quat_from_rotvec, quat_mul, quat_normalize, quat_to_mat, tilt_of, yaw_of

# -- layout of the state arrays ------------------------------------------------------
#: nominal state x: p 0:3, v 3:6, q 6:10, ba 10:13, bg 13:16
NX = 16
#: error state: dp 0:3, dv 3:6, dtheta 6:9, clone dp 9:12, clone dyaw 12, dba 13:16, dbg 16:19
NE = 19
N_NO_BIAS = 13

# istate (int64) fields
(I_ALIGNED, I_ALIGN_N, I_IN_STANCE, I_SWING_N, I_STANCE_N, I_N, I_GAPS, I_HAS_T, I_EVENTS,
 I_ZARU_REJECTED, I_FLOOR, I_STAIRS, I_PENDING) = range(13)
N_ISTATE = 13
# fstate (float64) fields
F_T_PREV, F_T_EVENT = 0, 1
F_STANCE_X, F_STANCE_Y, F_STANCE_Z = 2, 3, 4  # position at the last stance onset
F_ALIGN_ACC, F_ALIGN_GYRO = 5, 8            # 3 sums each
F_T_STILL = 11                              # time of the last event within the current stance
F_CORR = 12                                 # 3: position correction of the current sample
F_STANCE_T0 = 15                            # time the current stance began
F_QUIET = 16                                # 8: running mean and mean square of |f|, gyro xyz
F_FLOOR_Z = 24                              # height of the current level floor (I_FLOOR set)
F_ONSET_CORR = 25                           # 3: position correction at the stance onset
N_FSTATE = 28

#: The still start for a gyro-bias alignment is judged by how little the signals vary,
#: not by the ZUPT detector, whose statistic contains the very bias being measured (an
#: uncalibrated consumer gyro reads several deg/s at rest and never looks still to it).
QUIET_TAU = 0.25        # [s] time constant of the running mean / mean square
QUIET_GYRO_STD = 0.02   # [rad/s] sway of a foot resting under a standing person, plus noise
QUIET_ACC_STD = 0.1     # [m/s^2] the same for the specific-force magnitude

# event rows
E_T, E_T_PREV, E_POS, E_YAW, E_TILT, E_KIND, E_SWING_N, E_CORR, E_STANCE_T0 = 0, 1, 2, 5, 6, 7, 8, 9, 12
E_COV_INC, E_COV_ABS = 13, 29               # 16 each: row-major 4x4 over (x, y, z, heading)
N_EVENT = 45
EVENT_STEP, EVENT_STILL = 0, 1

# full-rate output columns; O_COV: upper triangle (row-major) of the 4x4 covariance of
# (x, y, z, yaw): xx, xy, xz, xyaw, yy, yz, yyaw, zz, zyaw, yawyaw
# O_ALIGNED: 1 once the filter navigates (rows before hold the origin)
O_T, O_POS, O_VEL, O_Q, O_ZV, O_YAW, O_COV, O_ALIGNED = 0, 1, 4, 7, 11, 12, 13, 23
N_OUT = 24
_COV_IDX = (0, 1, 2, 8)


class FilterConfig(NamedTuple):
    """Numeric configuration of the filter kernel (SI units; built from the plugin Params)."""

    gravity: float                 # [m/s^2]
    accel_noise: float             # accelerometer white noise density [m/s^2/sqrt(Hz)]
    gyro_noise: float              # gyro white noise density [rad/s/sqrt(Hz)]
    accel_bias_rw: float           # accelerometer bias random walk [m/s^3/sqrt(Hz)]
    gyro_bias_rw: float            # gyro bias random walk [rad/s^2/sqrt(Hz)]
    bias_states: bool              # estimate ba, bg
    init_accel_bias_sigma: float   # [m/s^2]
    init_gyro_bias_sigma: float    # [rad/s]
    init_tilt_sigma: float         # roll/pitch after coarse alignment [rad]
    init_yaw_sigma: float          # [rad] (the INS frame's yaw is defined by the start, ~0)
    zupt_sigma: float              # [m/s]
    zaru: bool                     # zero angular rate updates in long stances (needs bias states)
    zaru_after: float              # [s] stance duration after which ZARU applies
    zaru_sigma: float              # [rad/s]
    zaru_gate: float               # chi-square (3 dof) gate on the ZARU innovation
    align_samples: int             # still samples averaged for the coarse alignment
    align_min_samples: int         # a still period this long that ends sooner is used instead
    align_gyro_bias: bool          # take the mean gyro over the alignment as initial bias
    height_correction: bool        # hold level stance sequences at their floor's height
    level_threshold: float         # [m] |dz| between stances below which the floor is level
    level_sigma: float             # [m] sigma of the level-floor height measurement
    stair_run: float               # [m] horizontal step length no stair step reaches
    still_period: float            # [s] event period while standing still
    step_settle: float             # [s] a step event waits this long into its stance
    max_dt: float                  # [s] longer sample intervals are capped (and counted)


def new_state(cfg: FilterConfig) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Fresh (x, P, istate, fstate) arrays: unaligned, at the origin."""
    x = np.zeros(NX)
    x[6] = 1.0
    return x, np.zeros((NE, NE)), np.zeros(N_ISTATE, np.int64), np.zeros(N_FSTATE)


@njit(cache=True)
def _propagate_cov(P: np.ndarray, n: int, dt: float, R: np.ndarray, fn: np.ndarray,
                   cfg: FilterConfig) -> None:
    """P <- F P F^T + Q in place, using the block sparsity of F (see module docstring)."""
    # M = F P (row operations on a copy)
    M = P.copy()
    bias = n > N_NO_BIAS
    for j in range(n):
        for i in range(3):
            M[i, j] += dt * P[3 + i, j]
        # row block v: -dt [fn]x P_theta  (- dt R P_ba)
        t0, t1, t2 = P[6, j], P[7, j], P[8, j]
        M[3, j] += -dt * (fn[1] * t2 - fn[2] * t1)
        M[4, j] += -dt * (fn[2] * t0 - fn[0] * t2)
        M[5, j] += -dt * (fn[0] * t1 - fn[1] * t0)
        if bias:
            for i in range(3):
                M[3 + i, j] -= dt * (R[i, 0] * P[13, j] + R[i, 1] * P[14, j] + R[i, 2] * P[15, j])
                M[6 + i, j] -= dt * (R[i, 0] * P[16, j] + R[i, 1] * P[17, j] + R[i, 2] * P[18, j])
    # P = M F^T (the same operations on columns)
    for i in range(n):
        for c in range(3):
            P[i, c] = M[i, c] + dt * M[i, 3 + c]
        t0, t1, t2 = M[i, 6], M[i, 7], M[i, 8]
        P[i, 3] = M[i, 3] - dt * (fn[1] * t2 - fn[2] * t1)
        P[i, 4] = M[i, 4] - dt * (fn[2] * t0 - fn[0] * t2)
        P[i, 5] = M[i, 5] - dt * (fn[0] * t1 - fn[1] * t0)
        for c in range(6, n):
            P[i, c] = M[i, c]
        if bias:
            for c in range(3):
                P[i, 3 + c] -= dt * (R[c, 0] * M[i, 13] + R[c, 1] * M[i, 14] + R[c, 2] * M[i, 15])
                P[i, 6 + c] -= dt * (R[c, 0] * M[i, 16] + R[c, 1] * M[i, 17] + R[c, 2] * M[i, 18])
    qa = cfg.accel_noise * cfg.accel_noise * dt
    qg = cfg.gyro_noise * cfg.gyro_noise * dt
    for i in range(3):
        P[3 + i, 3 + i] += qa
        P[6 + i, 6 + i] += qg
    if bias:
        qba = cfg.accel_bias_rw * cfg.accel_bias_rw * dt
        qbg = cfg.gyro_bias_rw * cfg.gyro_bias_rw * dt
        for i in range(3):
            P[13 + i, 13 + i] += qba
            P[16 + i, 16 + i] += qbg


@njit(cache=True)
def _innovation_cov(P: np.ndarray, rows: np.ndarray, var: float) -> np.ndarray:
    """S = H P H^T + var I for a measurement selecting error-state ``rows`` (H = I[rows])."""
    m = rows.shape[0]
    S = np.empty((m, m))
    for a in range(m):
        for b in range(m):
            S[a, b] = P[rows[a], rows[b]]
        S[a, a] += var
    return S


@njit(cache=True)
def _update(x: np.ndarray, P: np.ndarray, n: int, rows: np.ndarray, resid: np.ndarray,
            var: float, corr: np.ndarray) -> None:
    """Kalman update with a measurement selecting error-state ``rows`` (H = I[rows]).

    ``resid`` is z - h(x); measurement noise ``var * I``. Injects the error into the
    nominal state (the clone rows are covariance bookkeeping only) and adds the
    position correction to ``corr``.
    """
    m = rows.shape[0]
    Si = np.linalg.inv(_innovation_cov(P, rows, var))
    U = np.empty((n, m))                    # P H^T
    for i in range(n):
        for a in range(m):
            U[i, a] = P[i, rows[a]]
    K = U @ Si                              # n x m
    dx = K @ resid
    # P <- P - K H P = P - U S^-1 U^T, written symmetrically
    for i in range(n):
        for j in range(i, n):
            s = 0.0
            for a in range(m):
                s += K[i, a] * U[j, a]
            v = P[i, j] - s
            P[i, j] = v
            P[j, i] = v
    for i in range(3):
        x[i] += dx[i]
        x[3 + i] += dx[3 + i]
        corr[i] += dx[i]
    dq = quat_from_rotvec(dx[6], dx[7], dx[8])
    q = quat_mul(dq, x[6:10])
    quat_normalize(q)
    x[6:10] = q
    if n > N_NO_BIAS:
        for i in range(3):
            x[10 + i] += dx[13 + i]
            x[13 + i] += dx[16 + i]


@njit(cache=True)
def _mahalanobis(P: np.ndarray, rows: np.ndarray, resid: np.ndarray, var: float) -> float:
    """Squared Mahalanobis distance of an innovation for H = I[rows], noise var * I."""
    return float(resid @ np.linalg.solve(_innovation_cov(P, rows, var), resid))


@njit(cache=True)
def _clone(P: np.ndarray, n: int) -> None:
    """Restart the step clone at the current (p, yaw): clone rows := state rows."""
    src = np.array([0, 1, 2, 8])
    for a in range(4):
        for j in range(n):
            P[9 + a, j] = P[src[a], j]
    for a in range(4):
        for j in range(n):
            P[j, 9 + a] = P[j, src[a]]


@njit(cache=True)
def _write_event(ev: np.ndarray, x: np.ndarray, P: np.ndarray, fs: np.ndarray, t: float,
                 kind: int, swing_n: int, corr: int) -> None:
    """Fill one event row: pose, the increment covariance (clone) and the absolute one;
    the position correction is the 3 values of ``fs`` at ``corr``."""
    ev[E_T] = t
    ev[E_T_PREV] = fs[F_T_EVENT]
    ev[E_POS:E_POS + 3] = x[0:3]
    q = x[6:10]
    ev[E_YAW] = yaw_of(q)
    ev[E_TILT] = tilt_of(q)
    ev[E_KIND] = kind
    ev[E_SWING_N] = swing_n
    ev[E_CORR:E_CORR + 3] = fs[corr:corr + 3]
    ev[E_STANCE_T0] = fs[F_STANCE_T0]
    cur = (0, 1, 2, 8)
    cl = (9, 10, 11, 12)
    for a in range(4):
        for b in range(4):
            inc = P[cur[a], cur[b]] + P[cl[a], cl[b]] - P[cur[a], cl[b]] - P[cl[a], cur[b]]
            ev[E_COV_INC + 4 * a + b] = inc
            ev[E_COV_ABS + 4 * a + b] = P[cur[a], cur[b]]


@njit(cache=True)
def _write_out(row: np.ndarray, t: float, x: np.ndarray, P: np.ndarray, still: bool,
               aligned: bool) -> None:
    """One full-rate output row (see the O_* columns)."""
    row[O_T] = t
    row[O_ALIGNED] = 1.0 if aligned else 0.0
    row[O_POS:O_POS + 6] = x[0:6]
    row[O_Q:O_Q + 4] = x[6:10]
    row[O_ZV] = 1.0 if still else 0.0
    row[O_YAW] = yaw_of(x[6:10])
    c = O_COV
    for a in range(4):
        for b in range(a, 4):
            row[c] = P[_COV_IDX[a], _COV_IDX[b]]
            c += 1


@njit(cache=True)
def _quiet(fs: np.ndarray, acc: np.ndarray, gyro: np.ndarray, dt: float, n: int,
           cfg: FilterConfig) -> bool:
    """Update the running signal statistics; True when the IMU has been quiet for a while."""
    a = 1.0 if n <= 1 or dt <= 0.0 else min(1.0, dt / QUIET_TAU)
    f = math.sqrt(acc[0] * acc[0] + acc[1] * acc[1] + acc[2] * acc[2])
    vals = (f, gyro[0], gyro[1], gyro[2])
    var_f = 0.0
    var_g = 0.0
    for i in range(4):
        m = fs[F_QUIET + 2 * i] + a * (vals[i] - fs[F_QUIET + 2 * i])
        sq = fs[F_QUIET + 2 * i + 1] + a * (vals[i] * vals[i] - fs[F_QUIET + 2 * i + 1])
        fs[F_QUIET + 2 * i] = m
        fs[F_QUIET + 2 * i + 1] = sq
        if i == 0:
            var_f = max(sq - m * m, 0.0)
        else:
            var_g += max(sq - m * m, 0.0)
    if dt <= 0.0 or n * dt < QUIET_TAU:
        return False
    per_sample = 1.0 / math.sqrt(dt)
    return (math.sqrt(var_g) < QUIET_GYRO_STD + 3.0 * cfg.gyro_noise * per_sample
            and math.sqrt(var_f) < QUIET_ACC_STD + 3.0 * cfg.accel_noise * per_sample)


@njit(cache=True)
def _start_navigation(x: np.ndarray, P: np.ndarray, ist: np.ndarray, fs: np.ndarray,
                      cfg: FilterConfig, t_still: float) -> None:
    """Align and start navigating in stance at ``t_still`` (the last still sample)."""
    _align(x, P, ist, fs, cfg)
    fs[F_T_EVENT] = t_still
    ist[I_IN_STANCE] = 1
    fs[F_STANCE_T0] = t_still
    fs[F_T_STILL] = t_still


@njit(cache=True)
def _align(x: np.ndarray, P: np.ndarray, ist: np.ndarray, fs: np.ndarray, cfg: FilterConfig) -> None:
    """Coarse alignment from the mean specific force of the still samples."""
    k = ist[I_ALIGN_N]
    fx, fy, fz = fs[F_ALIGN_ACC] / k, fs[F_ALIGN_ACC + 1] / k, fs[F_ALIGN_ACC + 2] / k
    x[:] = 0.0
    x[6:10] = level_quat(fx, fy, fz)
    if cfg.align_gyro_bias:
        for i in range(3):
            x[13 + i] = fs[F_ALIGN_GYRO + i] / k
    P[:, :] = 0.0
    for i in range(3):
        P[3 + i, 3 + i] = cfg.zupt_sigma * cfg.zupt_sigma
    P[6, 6] = P[7, 7] = cfg.init_tilt_sigma * cfg.init_tilt_sigma
    P[8, 8] = cfg.init_yaw_sigma * cfg.init_yaw_sigma
    if cfg.bias_states:
        for i in range(3):
            P[13 + i, 13 + i] = cfg.init_accel_bias_sigma * cfg.init_accel_bias_sigma
            P[16 + i, 16 + i] = cfg.init_gyro_bias_sigma * cfg.init_gyro_bias_sigma
    _clone(P, NE)
    ist[I_ALIGNED] = 1
    fs[F_STANCE_X] = fs[F_STANCE_Y] = fs[F_STANCE_Z] = 0.0
    ist[I_FLOOR] = ist[I_STAIRS] = 0


@njit(cache=True)
def _emit_step(events: np.ndarray, n_ev: int, x: np.ndarray, P: np.ndarray, n: int,
               ist: np.ndarray, fs: np.ndarray, t: float) -> int:
    """Write the pending step event at ``t`` (a still sample of its stance) and restart
    the step clone there; returns the new event count."""
    _write_event(events[n_ev], x, P, fs, t, EVENT_STEP, ist[I_SWING_N], F_ONSET_CORR)
    fs[F_T_EVENT] = t
    fs[F_T_STILL] = t
    _clone(P, n)
    ist[I_PENDING] = 0
    return n_ev + 1


@njit(cache=True)
def finish_filter(x: np.ndarray, P: np.ndarray, ist: np.ndarray, fs: np.ndarray,
                  cfg: FilterConfig, events: np.ndarray) -> int:
    """At the end of the recording: write a step still waiting for step_settle (the
    recording ended in its stance); returns the number of events written (0 or 1)."""
    if ist[I_PENDING] == 0:
        return 0
    n = NE if cfg.bias_states else N_NO_BIAS
    n_ev = _emit_step(events, 0, x, P, n, ist, fs, fs[F_T_PREV])
    ist[I_EVENTS] += n_ev
    return n_ev


@njit(cache=True)
def _level_floor(x: np.ndarray, P: np.ndarray, n: int, ist: np.ndarray, fs: np.ndarray,
                 cfg: FilterConfig) -> None:
    """Hold the height of a level stance sequence at its floor's (the stance onset).

    A step is a *stair step* when it is short (horizontally less than ``stair_run`` from
    the previous stance: one foot's stride on stairs spans two treads) and its height
    changed by ``level_threshold`` or more; every other step is *level* (a long step is a
    walking or running stride on a floor, where the height change is the INS's error).
    Stairs come in flights: a second stair step in the same direction ends the level
    sequence, and the next level step starts a new one at its own height; a single stair
    step followed by a level one is taken for an error. The first step of a level
    sequence fixes the floor's height, and every later one is pulled to it by a
    height-only update: gain ``k = P / (P + sigma^2)`` on z alone, so no other state
    changes (the horizontal track is the same with it or without), with
    ``P = max(P_zz, d^2)`` for a departure ``d`` from the floor (a filter that has drifted
    further than its covariance says is not believed over the floor), and the covariance
    in Joseph form for that gain (z row and column scaled by ``1 - k``,
    ``P_zz = (1 - k)^2 P + k^2 sigma^2``). A drift of a level threshold away from the
    floor in short level steps (a ramp) starts a new floor there.

    zupt-extension ("Height"): a stance slightly above or below the height at the last
    ZUPT is corrected to it; here the reference is the floor of the whole level sequence
    (the height cannot wander step by step) and the update reaches no other state (a
    wrong height cannot tilt the attitude, and the horizontal track with it).
    """
    long_step = math.hypot(x[0] - fs[F_STANCE_X], x[1] - fs[F_STANCE_Y]) >= cfg.stair_run
    rise = x[2] - fs[F_STANCE_Z]
    if not long_step and abs(rise) >= cfg.level_threshold:
        way = 1 if rise > 0 else -1
        ist[I_STAIRS] = ist[I_STAIRS] + way if ist[I_STAIRS] * way > 0 else way
        if abs(ist[I_STAIRS]) >= 2:
            ist[I_FLOOR] = 0
        return
    single = ist[I_STAIRS] != 0
    ist[I_STAIRS] = 0
    d = fs[F_FLOOR_Z] - x[2]
    if ist[I_FLOOR] == 0 or (not long_step and not single and abs(d) >= cfg.level_threshold):
        ist[I_FLOOR] = 1
        fs[F_FLOOR_Z] = x[2]
        return
    var = cfg.level_sigma * cfg.level_sigma
    pzz = max(P[2, 2], d * d)
    k = pzz / (pzz + var)
    x[2] += k * d
    fs[F_CORR + 2] += k * d
    for j in range(n):
        if j != 2:
            P[2, j] *= 1.0 - k
            P[j, 2] = P[2, j]
    P[2, 2] = (1.0 - k) * (1.0 - k) * pzz + k * k * var


@njit(cache=True, nogil=True)  # releases the GIL: firefighters run on worker threads
def run_filter(t: np.ndarray, acc: np.ndarray, gyro: np.ndarray, zv: np.ndarray,
               x: np.ndarray, P: np.ndarray, ist: np.ndarray, fs: np.ndarray,
               cfg: FilterConfig, out: np.ndarray, events: np.ndarray) -> int:
    """Run the INS over samples (t [s], acc [m/s^2] FLU, gyro [rad/s] FLU, zv flags).

    Writes one row per sample into ``out`` (N_OUT columns; rows before the alignment
    hold the origin and zv) and step/still events into ``events``; returns the number
    of events written. ``x, P, ist, fs`` carry the filter between calls.
    """
    n = NE if cfg.bias_states else N_NO_BIAS
    n_ev = 0
    z3 = np.zeros(3)
    vrows = np.array([3, 4, 5])
    bgrows = np.array([16, 17, 18])
    wres = np.zeros(3)
    for k in range(t.shape[0]):
        tk = t[k]
        still = zv[k]
        if ist[I_HAS_T] == 0:
            dt = 0.0
            ist[I_HAS_T] = 1
        else:
            dt = tk - fs[F_T_PREV]
            if dt > cfg.max_dt:
                dt = cfg.max_dt
                ist[I_GAPS] += 1
        if ist[I_PENDING] == 1 and not still:
            # the stance ended before step_settle: its step is the last still sample's
            # state (x, P have not moved on yet)
            n_ev = _emit_step(events, n_ev, x, P, n, ist, fs, fs[F_T_PREV])
        fs[F_T_PREV] = tk
        ist[I_N] += 1
        fs[F_CORR:F_CORR + 3] = z3
        if ist[I_ALIGNED] == 0:
            if cfg.align_gyro_bias:  # a still start is promised: judge it bias-free
                still = _quiet(fs, acc[k], gyro[k], dt, ist[I_N], cfg)
            if still:
                for i in range(3):
                    fs[F_ALIGN_ACC + i] += acc[k, i]
                    fs[F_ALIGN_GYRO + i] += gyro[k, i]
                ist[I_ALIGN_N] += 1
                if ist[I_ALIGN_N] >= cfg.align_samples:
                    _start_navigation(x, P, ist, fs, cfg, tk)
                _write_out(out[k], tk, x, P, still, ist[I_ALIGNED] == 1)
                continue
            if ist[I_ALIGN_N] < cfg.align_min_samples:
                ist[I_ALIGN_N] = 0
                fs[F_ALIGN_ACC:F_ALIGN_ACC + 6] = 0.0
                _write_out(out[k], tk, x, P, still, False)
                continue
            # A still period shorter than the alignment duration has just ended (a noisy
            # sensor's detector flickers; walking stances are short): align on it rather
            # than wait for ever, and navigate this first moving sample.
            _start_navigation(x, P, ist, fs, cfg, tk - dt)  # the previous sample was still
        # -- strapdown mechanisation ---------------------------------------------------
        if dt > 0.0:
            wx, wy, wz = gyro[k, 0] - x[13], gyro[k, 1] - x[14], gyro[k, 2] - x[15]
            dq = quat_from_rotvec(wx * dt, wy * dt, wz * dt)
            q = quat_mul(x[6:10], dq)
            quat_normalize(q)
            x[6:10] = q
            R = quat_to_mat(q)
            f0, f1, f2 = acc[k, 0] - x[10], acc[k, 1] - x[11], acc[k, 2] - x[12]
            fn = np.empty(3)
            for i in range(3):
                fn[i] = R[i, 0] * f0 + R[i, 1] * f1 + R[i, 2] * f2
            an2 = fn[2] - cfg.gravity
            x[0] += x[3] * dt + 0.5 * fn[0] * dt * dt
            x[1] += x[4] * dt + 0.5 * fn[1] * dt * dt
            x[2] += x[5] * dt + 0.5 * an2 * dt * dt
            x[3] += fn[0] * dt
            x[4] += fn[1] * dt
            x[5] += an2 * dt
            _propagate_cov(P, n, dt, R, fn, cfg)
        # -- zero-velocity update and stance bookkeeping --------------------------------
        if still:
            _update(x, P, n, vrows, -x[3:6], cfg.zupt_sigma * cfg.zupt_sigma, fs[F_CORR:F_CORR + 3])
            if ist[I_IN_STANCE] == 0:
                # stance onset: one step completed; its event waits for step_settle
                if cfg.height_correction:
                    _level_floor(x, P, n, ist, fs, cfg)
                fs[F_STANCE_X] = x[0]
                fs[F_STANCE_Y] = x[1]
                fs[F_STANCE_Z] = x[2]
                fs[F_STANCE_T0] = tk
                fs[F_ONSET_CORR:F_ONSET_CORR + 3] = fs[F_CORR:F_CORR + 3]
                ist[I_PENDING] = 1
                ist[I_IN_STANCE] = 1
                ist[I_STANCE_N] = 0
            elif ist[I_PENDING] == 0 and tk - fs[F_T_STILL] >= cfg.still_period:
                _write_event(events[n_ev], x, P, fs, tk, EVENT_STILL, 0, F_CORR)
                n_ev += 1
                fs[F_T_EVENT] = tk
                fs[F_T_STILL] = tk
                _clone(P, n)
            if cfg.zaru and n > N_NO_BIAS and tk - fs[F_STANCE_T0] >= cfg.zaru_after:
                # true rate 0 = (gyro - bg_est) - dbg: innovation gyro - bg_est against +dbg
                for i in range(3):
                    wres[i] = gyro[k, i] - x[13 + i]
                var = cfg.zaru_sigma * cfg.zaru_sigma
                if _mahalanobis(P, bgrows, wres, var) < cfg.zaru_gate:
                    _update(x, P, n, bgrows, wres, var, fs[F_CORR:F_CORR + 3])
                else:
                    ist[I_ZARU_REJECTED] += 1
            if ist[I_PENDING] == 1 and tk - fs[F_STANCE_T0] >= cfg.step_settle:
                n_ev = _emit_step(events, n_ev, x, P, n, ist, fs, tk)
            ist[I_STANCE_N] += 1
        else:
            if ist[I_IN_STANCE] == 1:
                ist[I_IN_STANCE] = 0
                ist[I_SWING_N] = 0
            ist[I_SWING_N] += 1
        _write_out(out[k], tk, x, P, still, True)
    ist[I_EVENTS] += n_ev
    return n_ev
