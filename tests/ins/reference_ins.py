"""A straightforward reference implementation of the ZUPT-aided INS, for checking.

Same algorithm as ``firenav_plugins.estimators.zupt_ins`` (detectors, strapdown,
error-state Kalman filter, alignment, ZARU, level-floor height update, step events),
written the plain way: the detector statistic and thresholds over the whole recording
with array slices, the filter as a Python loop over samples with dense matrices
(``P = F P F^T + Q``, ``K = P H^T S^-1``, ``P = (I - K H) P``). The package's numba
kernels must give the same numbers (tests/ins/test_reference_equality.py); the speed
benchmark runs both side by side.
"""
from __future__ import annotations

import math

import numpy as np

from firenav_plugins.estimators.zupt_ins import detectors, eskf
from firenav_plugins.estimators.zupt_ins.detectors import DetectorConfig
from firenav_plugins.estimators.zupt_ins.eskf import FilterConfig


# -- rotations ------------------------------------------------------------------------
def qmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
                     w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
                     w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])


def qexp(v: np.ndarray) -> np.ndarray:
    angle = float(np.linalg.norm(v))
    if angle < 1e-12:
        return np.array([1.0 - angle * angle / 8.0, *(0.5 * v)])
    return np.array([math.cos(angle / 2), *(math.sin(angle / 2) / angle * v)])


def qnorm(q: np.ndarray) -> np.ndarray:
    q = q / np.linalg.norm(q)
    return -q if q[0] < 0 else q


def qmat(q: np.ndarray) -> np.ndarray:
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def skew(v: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def yaw(q: np.ndarray) -> float:
    r = qmat(q)
    return math.atan2(r[1, 0], r[0, 0])


def tilt(q: np.ndarray) -> float:
    return math.acos(max(-1.0, min(1.0, qmat(q)[2, 2])))


def level(f: np.ndarray) -> np.ndarray:
    roll = math.atan2(f[1], f[2])
    pitch = math.atan2(-f[0], math.hypot(f[1], f[2]))
    cr, sr, cp, sp = math.cos(roll / 2), math.sin(roll / 2), math.cos(pitch / 2), math.sin(pitch / 2)
    return qmul(np.array([cp, 0.0, sp, 0.0]), np.array([cr, sr, 0.0, 0.0]))


# -- detector -------------------------------------------------------------------------
def statistic(acc: np.ndarray, gyro: np.ndarray, cfg: DetectorConfig
              ) -> tuple[np.ndarray, np.ndarray]:
    """log10 T and ``up`` (z of the mean specific force's direction, 1 unless that mean
    is gravity) of every sample, windows centred and truncated at both ends."""
    n, h = len(acc), cfg.window // 2
    out, up = np.empty(n), np.empty(n)
    for k in range(n):
        a, w = acc[max(0, k - h):k + h + 1], gyro[max(0, k - h):k + h + 1]
        m = a.mean(axis=0)
        norm = np.linalg.norm(m)
        up[k] = m[2] / norm if abs(norm - cfg.gravity) < detectors.REST_GRAVITY * cfg.gravity else 1.0
        if cfg.kind == detectors.AMVD:
            tot = np.sum((a - a.mean(axis=0)) ** 2) / cfg.sigma_a ** 2
        elif cfg.kind == detectors.ARED:
            tot = np.sum(w ** 2) / cfg.sigma_g ** 2
        else:
            m = a.mean(axis=0)
            u = cfg.gravity * m / np.linalg.norm(m)
            tot = np.sum((a - u) ** 2) / cfg.sigma_a ** 2 + np.sum(w ** 2) / cfg.sigma_g ** 2
        out[k] = math.log10(max(tot / len(a), 1e-300))
    return out, up


def decide(s: np.ndarray, up: np.ndarray, cfg: DetectorConfig
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Zero-velocity flags, thresholds (log10) and gait modes of every sample."""
    n = len(s)
    thr, mode, test = np.empty(n), np.zeros(n), s.copy()
    for d in range(n):
        if cfg.kind != detectors.ADAPTIVE:
            thr[d] = math.log10(cfg.threshold)
            continue
        hi = min(d + cfg.ahead, n - 1) + 1
        swing = s[max(0, d - cfg.back):hi].max()
        lo = max(0, d - cfg.floor_back)
        window = s[lo:hi]
        j = lo + len(window) - 1 - int(np.argmin(window[::-1]))   # the newest minimum
        floor = s[j]
        if up[j] < cfg.crawl_up:
            mode[d] = detectors.MODE_CRAWL
            low, high = math.log10(cfg.crawl_low), math.log10(cfg.crawl_high)
            kappa, prominence = cfg.crawl_kappa, cfg.crawl_prominence
            h = cfg.crawl_half
            test[d] = math.log10(max(np.mean(10.0 ** s[max(0, d - h):min(d + h, n - 1) + 1]),
                                     1e-300))
        else:
            low, high = math.log10(cfg.low), math.log10(cfg.high)
            kappa, prominence = cfg.kappa, cfg.prominence
        if swing - floor < prominence:
            thr[d] = low
        else:
            thr[d] = min(max(floor + kappa * (swing - floor), low), high)
    zv = test < thr
    # drop the samples of zero-velocity runs shorter than their mode's min_stance
    need = np.where(mode == detectors.MODE_CRAWL, cfg.crawl_min_stance, cfg.min_stance)
    edges = np.flatnonzero(np.diff(np.concatenate(([0], zv.astype(int), [0]))))
    keep = zv.copy()
    for start, end in zip(edges[::2], edges[1::2]):
        keep[start:end] = end - start >= need[start:end]
    return keep, thr, mode


# -- filter ---------------------------------------------------------------------------
def run_filter(t: np.ndarray, acc: np.ndarray, gyro: np.ndarray, zv: np.ndarray,
               cfg: FilterConfig) -> tuple[np.ndarray, np.ndarray]:
    """Full-rate states (N, eskf.N_OUT) and events (M, eskf.N_EVENT), as the kernel."""
    n = eskf.NE if cfg.bias_states else eskf.N_NO_BIAS
    p, v, q = np.zeros(3), np.zeros(3), np.array([1.0, 0, 0, 0])
    ba, bg = np.zeros(3), np.zeros(3)
    P = np.zeros((n, n))
    aligned, align_acc, align_gyro, align_n = False, np.zeros(3), np.zeros(3), 0
    in_stance, swing_n, stance_t0, t_event, t_still, stance_z = False, 0, 0.0, 0.0, 0.0, 0.0
    floor_z = None                # height of the current level floor
    stance_xy = np.zeros(2)       # horizontal position at the last stance onset
    stairs = 0                    # consecutive stair steps, signed (up +)
    t_prev = None
    out = np.zeros((len(t), eskf.N_OUT))
    events = []
    cur, cl = [0, 1, 2, 8], [9, 10, 11, 12]

    def clone():
        P[cl, :] = P[cur, :]
        P[:, cl] = P[:, cur]

    def update(H, resid, var):
        nonlocal p, v, q, ba, bg
        S = H @ P @ H.T + var * np.eye(len(resid))
        K = P @ H.T @ np.linalg.inv(S)
        dx = K @ resid
        P[:] = (np.eye(n) - K @ H) @ P
        P[:] = (P + P.T) / 2
        p, v = p + dx[0:3], v + dx[3:6]
        q = qnorm(qmul(qexp(dx[6:9]), q))
        if n > eskf.N_NO_BIAS:
            ba, bg = ba + dx[13:16], bg + dx[16:19]
        return dx[0:3]

    def event(tk, kind, corr):
        row = np.zeros(eskf.N_EVENT)
        row[eskf.E_T], row[eskf.E_T_PREV] = tk, t_event
        row[eskf.E_POS:eskf.E_POS + 3] = p
        row[eskf.E_YAW], row[eskf.E_TILT], row[eskf.E_KIND] = yaw(q), tilt(q), kind
        row[eskf.E_SWING_N] = swing_n if kind == eskf.EVENT_STEP else 0
        row[eskf.E_CORR:eskf.E_CORR + 3] = corr
        row[eskf.E_STANCE_T0] = stance_t0
        S = np.zeros((4, n))
        S[range(4), cur] = 1.0
        S[range(4), cl] = -1.0
        row[eskf.E_COV_INC:eskf.E_COV_INC + 16] = (S @ P @ S.T).ravel()
        row[eskf.E_COV_ABS:eskf.E_COV_ABS + 16] = P[np.ix_(cur, cur)].ravel()
        events.append(row)

    def sel(rows):
        H = np.zeros((len(rows), n))
        H[range(len(rows)), rows] = 1.0
        return H

    pending, stance_corr = False, np.zeros(3)   # a step waiting for step_settle, and the
                                                # position correction at its onset

    def step(t_step):
        nonlocal t_event, t_still, pending
        event(t_step, eskf.EVENT_STEP, stance_corr)
        t_event = t_still = t_step
        clone()
        pending = False

    for k, tk in enumerate(t):
        dt = 0.0 if t_prev is None else min(tk - t_prev, cfg.max_dt)
        if pending and not zv[k]:
            step(t_prev)        # the stance ended before settling: its last still sample
        t_prev = tk
        corr = np.zeros(3)
        if not aligned:
            if zv[k]:
                align_acc += acc[k]
                align_gyro += gyro[k]
                align_n += 1
                if align_n >= cfg.align_samples:
                    aligned = True
                    floor_z, stance_xy, stance_z, stairs = None, np.zeros(2), 0.0, 0
                    q = level(align_acc / align_n)
                    if cfg.align_gyro_bias:
                        bg = align_gyro / align_n
                    P[:] = 0.0
                    P[3:6, 3:6] = cfg.zupt_sigma ** 2 * np.eye(3)
                    P[6, 6] = P[7, 7] = cfg.init_tilt_sigma ** 2
                    P[8, 8] = cfg.init_yaw_sigma ** 2
                    if n > eskf.N_NO_BIAS:
                        P[13:16, 13:16] = cfg.init_accel_bias_sigma ** 2 * np.eye(3)
                        P[16:19, 16:19] = cfg.init_gyro_bias_sigma ** 2 * np.eye(3)
                    clone()
                    in_stance, stance_t0, t_event, t_still = True, tk, tk, tk
            else:
                align_acc[:], align_gyro[:], align_n = 0.0, 0.0, 0
        else:
            if dt > 0:
                q = qnorm(qmul(q, qexp((gyro[k] - bg) * dt)))
                R = qmat(q)
                fn = R @ (acc[k] - ba)
                a = fn - np.array([0.0, 0.0, cfg.gravity])
                p = p + v * dt + 0.5 * a * dt * dt
                v = v + a * dt
                A = np.zeros((n, n))
                A[0:3, 3:6] = np.eye(3)
                A[3:6, 6:9] = -skew(fn)
                Q = np.zeros((n, n))
                Q[3:6, 3:6] = cfg.accel_noise ** 2 * dt * np.eye(3)
                Q[6:9, 6:9] = cfg.gyro_noise ** 2 * dt * np.eye(3)
                if n > eskf.N_NO_BIAS:
                    A[3:6, 13:16] = -R
                    A[6:9, 16:19] = -R
                    Q[13:16, 13:16] = cfg.accel_bias_rw ** 2 * dt * np.eye(3)
                    Q[16:19, 16:19] = cfg.gyro_bias_rw ** 2 * dt * np.eye(3)
                F = np.eye(n) + dt * A
                P[:] = F @ P @ F.T + Q
            if zv[k]:
                corr += update(sel([3, 4, 5]), -v, cfg.zupt_sigma ** 2)
                if not in_stance:
                    if cfg.height_correction:
                        long_step = math.hypot(*(p[:2] - stance_xy)) >= cfg.stair_run
                        rise = p[2] - stance_z
                        if not long_step and abs(rise) >= cfg.level_threshold:
                            way = 1 if rise > 0 else -1
                            stairs = stairs + way if stairs * way > 0 else way
                            if abs(stairs) >= 2:
                                floor_z = None
                        else:
                            single, stairs = stairs != 0, 0
                            if floor_z is None or (not long_step and not single and
                                                   abs(floor_z - p[2]) >= cfg.level_threshold):
                                floor_z = p[2]
                            else:   # height-only update, Joseph form for the gain on z alone
                                d = floor_z - p[2]
                                prior = max(P[2, 2], d * d)
                                gain = prior / (prior + cfg.level_sigma ** 2)
                                p = p + np.array([0.0, 0.0, gain * d])
                                corr[2] += gain * d
                                P[2, 2] = prior
                                A = np.eye(n)
                                A[2, 2] = 1.0 - gain
                                P[:] = A @ P @ A.T
                                P[2, 2] += gain * gain * cfg.level_sigma ** 2
                    stance_xy, stance_z, stance_t0 = p[:2].copy(), p[2], tk
                    stance_corr, pending, in_stance = corr.copy(), True, True
                elif not pending and tk - t_still >= cfg.still_period:
                    event(tk, eskf.EVENT_STILL, corr)
                    t_event = t_still = tk
                    clone()
                if cfg.zaru and n > eskf.N_NO_BIAS and tk - stance_t0 >= cfg.zaru_after:
                    w = gyro[k] - bg
                    H = sel([16, 17, 18])
                    S = H @ P @ H.T + cfg.zaru_sigma ** 2 * np.eye(3)
                    if w @ np.linalg.solve(S, w) < cfg.zaru_gate:
                        corr += update(H, w, cfg.zaru_sigma ** 2)
                if pending and tk - stance_t0 >= cfg.step_settle:
                    step(tk)
            else:
                if in_stance:
                    in_stance, swing_n = False, 0
                swing_n += 1
        row = out[k]
        row[eskf.O_T] = tk
        if aligned:
            row[eskf.O_POS:eskf.O_POS + 3], row[eskf.O_VEL:eskf.O_VEL + 3] = p, v
        row[eskf.O_Q:eskf.O_Q + 4] = q
        row[eskf.O_ZV] = float(zv[k])
        row[eskf.O_YAW] = yaw(q)
        row[eskf.O_COV:eskf.O_COV + 10] = P[np.ix_(cur, cur)][np.triu_indices(4)]
        row[eskf.O_ALIGNED] = float(aligned)
    if pending:
        step(t_prev)            # the recording ended in the stance
    return out, np.array(events).reshape(-1, eskf.N_EVENT)


def run(t: np.ndarray, acc: np.ndarray, gyro: np.ndarray, dcfg: DetectorConfig,
        fcfg: FilterConfig) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Detector then filter over a whole recording: (states, events, log10 statistic)."""
    s, up = statistic(acc, gyro, dcfg)
    zv, _, _ = decide(s, up, dcfg)
    states, events = run_filter(t, acc, gyro, zv, fcfg)
    return states, events, s
