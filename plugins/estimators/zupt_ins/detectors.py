"""Zero-velocity detectors as streaming numba kernels.

Each detector computes an energy statistic ``T_k`` over a window of ``W`` samples
centred on sample k (Skog, Händel, Nilsson, Rantakokko, "Zero-velocity detection — an
algorithm evaluation", IEEE Trans. Biomed. Eng. 2010; the detectors of PyShoe):

* ``shoe``  — SHOE, the GLRT of Skog et al.:
  ``T = 1/W sum( |a_j - g a_mean/|a_mean||^2 / sigma_a^2 + |w_j|^2 / sigma_w^2 )``
* ``ared``  — angular-rate energy: ``T = 1/W sum |w_j|^2 / sigma_w^2``
* ``amvd``  — acceleration moving variance: ``T = 1/W sum |a_j - a_mean|^2 / sigma_a^2``

The fixed detectors declare zero velocity when ``T_k < threshold``. The ``adaptive``
detector (designed here; how its defaults were chosen: ``docs/foot-ins.md``) works
on ``s_k = log10 T_k`` of SHOE and places the threshold of every sample between the
floor of the current stance and the level of the recent swing:

    floor_k = min  s_j  over k - Bf <= j <= k + A      (the latest stance)
    swing_k = max  s_j  over k - B  <= j <= k + A      (the latest swing)
    thr_k   = clip(floor_k + kappa * (swing_k - floor_k), log10 low, log10 high)
              or log10 low when swing_k - floor_k < prominence (no gait in view)
    zv_k    = s_k < thr_k

Why: the statistic of a resting foot rises by orders of magnitude with speed (about
10^5.5 when walking, 10^8 when running: the foot never quite stops), so any fixed
threshold is wrong for some gait, while at every speed a stance is the deepest dip
between two swings. ``Bf`` is shorter than a stride so that the floor follows a change
of gait within one stride; the prominence test keeps a foot that slides without
clear stances (shuffling) to the surely-still level ``low``.

Crawling (on hands and knees, or knee-walking) is a gait of its own: the boot rests on
its toe cap or upside down, rocks about the contact while the knee moves, and its
swings are slow, so the statistic of its stances sits far above a walking stance's and
that of its swings far below a walking swing's. The detector recognises it by the
attitude of the resting foot: when the mean specific force of the floor sample's window
is gravity (within ``REST_GRAVITY``) and points more than the crawl tilt away from the
IMU z axis (``up < crawl_up``), the threshold of that sample uses the crawl levels
``crawl_low``, ``crawl_high``, ``crawl_kappa`` and ``crawl_prominence`` instead, and
compares with it the mean of ``T`` over ``2 crawl_half + 1`` samples centred on the
sample (log10 of the mean): a crawling swing glides, its rotation slowing and
reversing, and ``T`` dips for a few tens of milliseconds as low as in a rocking stance;
a stance stays low for longer. The mode of each sample is handed on with its (raw)
statistic.

Every detector finally drops zero-velocity runs shorter than ``min_stance`` samples
(``crawl_min_stance`` for a sample in crawl mode):
mid-swing, when the foot's rotation reverses, the statistic can dip for a few
milliseconds at full walking speed; a real stance lasts longer even when running.

Streaming: samples go into a ring buffer; the decision for sample k is final once
sample ``k + lookahead`` has arrived, and the kernel hands sample k on together with
its decision, so the filter runs ``lookahead`` samples behind the input. Ring and
counters are arrays kept by the caller, so block boundaries change nothing.
:func:`flush` decides the last samples at the end of a recording (windows truncated
at the end, as they are at the start).
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

SHOE, ARED, AMVD, ADAPTIVE = 0, 1, 2, 3
DETECTOR_KINDS = {"shoe": SHOE, "ared": ARED, "amvd": AMVD, "adaptive": ADAPTIVE}

# ring columns: t, acc xyz, gyro xyz, log10 T, raw decision, threshold, up, gait mode
R_T, R_ACC, R_GYRO, R_STAT, R_RAW, R_THR, R_UP, R_MODE = 0, 1, 4, 7, 8, 9, 10, 11
N_RING = 12
#: gait modes of the adaptive detector (``BlockResult.stat`` column 2)
MODE_UPRIGHT, MODE_CRAWL = 0, 1
# counters: samples in / out, then head and tail of the max and min deques
D_N_IN, D_N_OUT, D_MAX_H, D_MAX_T, D_MIN_H, D_MIN_T = range(6)
N_DSTATE = 6
_TINY = 1e-300
#: A window whose mean specific force is within this fraction of gravity tells the
#: attitude of the foot (crawl mode); the mean of a moving foot's window does not.
REST_GRAVITY = 0.1


class DetectorConfig(NamedTuple):
    """Numeric detector configuration (windows in samples, statistics unitless)."""

    kind: int
    window: int             # W, odd
    sigma_a: float          # accelerometer noise normalising T [m/s^2]
    sigma_g: float          # gyro noise normalising T [rad/s]
    gravity: float          # [m/s^2]
    threshold: float        # fixed detectors: zv when T < threshold
    low: float              # adaptive: T below which the foot is surely still
    high: float             # adaptive: T above which it surely moves
    kappa: float            # adaptive: threshold position between floor and swing (0..1)
    prominence: float       # adaptive: decades from floor to swing that make a gait
    ahead: int              # adaptive: A, look-ahead [samples]
    back: int               # adaptive: B, look-back of the swing level [samples]
    floor_back: int         # adaptive: Bf, look-back of the stance floor [samples]
    min_stance: int         # shortest zero-velocity run kept [samples]
    crawl_up: float         # adaptive: cos of the resting-foot tilt beyond which it crawls
    crawl_low: float        # adaptive, crawling: low, high, kappa, prominence as above
    crawl_high: float
    crawl_kappa: float
    crawl_prominence: float
    crawl_min_stance: int   # shortest zero-velocity run kept while crawling [samples]
    crawl_half: int         # adaptive, crawling: half-span of the averaged statistic [samples]


def lookahead(cfg: DetectorConfig) -> int:
    """Samples by which the final decision lags the newest input."""
    raw = cfg.window // 2 + (cfg.ahead if cfg.kind == ADAPTIVE else 0)
    return raw + _longest_run(cfg) - 1


def capacity(cfg: DetectorConfig) -> int:
    """Ring size holding every sample a decision needs."""
    return lookahead(cfg) + max(cfg.back, cfg.floor_back) + 2 * _longest_run(cfg) + 2


@njit(cache=True)
def _longest_run(cfg: DetectorConfig) -> int:
    """The longest zero-velocity run a decision waits for [samples, >= 1]."""
    return max(cfg.min_stance, cfg.crawl_min_stance if cfg.kind == ADAPTIVE else 0, 1)


def new_state(cfg: DetectorConfig) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Fresh (ring, counters, monotonic deques of sample indices for the sliding max/min)."""
    qcap = max(cfg.back, cfg.floor_back) + cfg.ahead + 2
    return (np.zeros((capacity(cfg), N_RING)), np.zeros(N_DSTATE, np.int64),
            np.zeros((2, qcap), np.int64))


@njit(cache=True)
def _push(ring: np.ndarray, ist: np.ndarray, dq: np.ndarray, j: int) -> None:
    """Add sample j's statistic to the sliding-max (row 0) and sliding-min (row 1) deques.

    Each deque holds indices whose statistics decrease (max) / increase (min) from head
    to tail, so the head is the extreme of the window: O(1) amortised per sample.
    """
    m = ring.shape[0]
    cap = dq.shape[1]
    s = ring[j % m, R_STAT]
    t = ist[D_MAX_T]
    while t > ist[D_MAX_H] and ring[dq[0, (t - 1) % cap] % m, R_STAT] <= s:
        t -= 1
    dq[0, t % cap] = j
    ist[D_MAX_T] = t + 1
    t = ist[D_MIN_T]
    while t > ist[D_MIN_H] and ring[dq[1, (t - 1) % cap] % m, R_STAT] >= s:
        t -= 1
    dq[1, t % cap] = j
    ist[D_MIN_T] = t + 1


@njit(cache=True)
def _window_extremes(ring: np.ndarray, ist: np.ndarray, dq: np.ndarray, d: int,
                     cfg: DetectorConfig) -> tuple[float, int]:
    """(max over d-B.., index of the min over d-Bf..) of the statistics pushed so far
    (the newest sample of equal minima)."""
    m = ring.shape[0]
    cap = dq.shape[1]
    while dq[0, ist[D_MAX_H] % cap] < d - cfg.back:
        ist[D_MAX_H] += 1
    while dq[1, ist[D_MIN_H] % cap] < d - cfg.floor_back:
        ist[D_MIN_H] += 1
    return ring[dq[0, ist[D_MAX_H] % cap] % m, R_STAT], dq[1, ist[D_MIN_H] % cap]


@njit(cache=True)
def _statistic(ring: np.ndarray, lo: int, hi: int, cfg: DetectorConfig) -> tuple[float, float]:
    """(log10 T, up) over the samples lo..hi (absolute indices, inclusive); ``up`` is the
    z component of the mean specific force's direction (1 when the IMU z axis points up,
    the foot level), or 1 when the mean is not gravity (a moving foot's window says
    nothing about its attitude)."""
    m = ring.shape[0]
    w = hi - lo + 1
    sa0 = sa1 = sa2 = 0.0
    for j in range(lo, hi + 1):
        r = j % m
        sa0 += ring[r, R_ACC]
        sa1 += ring[r, R_ACC + 1]
        sa2 += ring[r, R_ACC + 2]
    ma0, ma1, ma2 = sa0 / w, sa1 / w, sa2 / w
    nrm = math.sqrt(ma0 * ma0 + ma1 * ma1 + ma2 * ma2)
    up = ma2 / nrm if abs(nrm - cfg.gravity) < REST_GRAVITY * cfg.gravity else 1.0
    ta = 0.0
    tw = 0.0
    if cfg.kind == AMVD:
        for j in range(lo, hi + 1):
            r = j % m
            d0, d1, d2 = ring[r, R_ACC] - ma0, ring[r, R_ACC + 1] - ma1, ring[r, R_ACC + 2] - ma2
            ta += d0 * d0 + d1 * d1 + d2 * d2
        tot = ta / (cfg.sigma_a * cfg.sigma_a)
    elif cfg.kind == ARED:
        for j in range(lo, hi + 1):
            r = j % m
            g0, g1, g2 = ring[r, R_GYRO], ring[r, R_GYRO + 1], ring[r, R_GYRO + 2]
            tw += g0 * g0 + g1 * g1 + g2 * g2
        tot = tw / (cfg.sigma_g * cfg.sigma_g)
    else:
        u0 = u1 = u2 = 0.0
        if nrm > 0.0:
            u0, u1, u2 = cfg.gravity * ma0 / nrm, cfg.gravity * ma1 / nrm, cfg.gravity * ma2 / nrm
        for j in range(lo, hi + 1):
            r = j % m
            d0, d1, d2 = ring[r, R_ACC] - u0, ring[r, R_ACC + 1] - u1, ring[r, R_ACC + 2] - u2
            g0, g1, g2 = ring[r, R_GYRO], ring[r, R_GYRO + 1], ring[r, R_GYRO + 2]
            ta += d0 * d0 + d1 * d1 + d2 * d2
            tw += g0 * g0 + g1 * g1 + g2 * g2
        tot = ta / (cfg.sigma_a * cfg.sigma_a) + tw / (cfg.sigma_g * cfg.sigma_g)
    return math.log10(max(tot / w, _TINY)), up


@njit(cache=True)
def _crawl_statistic(ring: np.ndarray, ist: np.ndarray, d: int, cfg: DetectorConfig) -> float:
    """log10 of the mean T over samples d - crawl_half .. d + crawl_half (those computed)."""
    m = ring.shape[0]
    lo = max(0, d - cfg.crawl_half)
    hi = min(d + cfg.crawl_half, ist[D_N_IN] - 1)
    tot = 0.0
    for j in range(lo, hi + 1):
        tot += 10.0 ** ring[j % m, R_STAT]
    return math.log10(max(tot / (hi - lo + 1), _TINY))


@njit(cache=True)
def _raw_decision(ring: np.ndarray, ist: np.ndarray, dq: np.ndarray, d: int,
                  cfg: DetectorConfig) -> None:
    """Threshold test of sample d (all statistics up to d + A pushed to the deques)."""
    m = ring.shape[0]
    r = d % m
    s = ring[r, R_STAT]
    mode = MODE_UPRIGHT
    if cfg.kind != ADAPTIVE:
        thr = math.log10(cfg.threshold)
    else:
        swing, j = _window_extremes(ring, ist, dq, d, cfg)
        floor = ring[j % m, R_STAT]
        if ring[j % m, R_UP] < cfg.crawl_up:
            mode = MODE_CRAWL
            low, high = math.log10(cfg.crawl_low), math.log10(cfg.crawl_high)
            kappa, prominence = cfg.crawl_kappa, cfg.crawl_prominence
            s = _crawl_statistic(ring, ist, d, cfg)
        else:
            low, high = math.log10(cfg.low), math.log10(cfg.high)
            kappa, prominence = cfg.kappa, cfg.prominence
        if swing - floor < prominence:
            thr = low
        else:
            thr = max(low, min(floor + kappa * (swing - floor), high))
    ring[r, R_THR] = thr
    ring[r, R_MODE] = mode
    ring[r, R_RAW] = 1.0 if s < thr else 0.0


@njit(cache=True)
def _final_decision(ring: np.ndarray, e: int, last: int, cfg: DetectorConfig) -> bool:
    """Raw decision of sample e, dropped when its run is shorter than its mode's
    ``min_stance``."""
    m = ring.shape[0]
    if ring[e % m, R_RAW] == 0.0:
        return False
    need = max(cfg.crawl_min_stance if ring[e % m, R_MODE] == MODE_CRAWL else cfg.min_stance, 1)
    run = 1
    j = e - 1
    while run < need and j >= 0 and ring[j % m, R_RAW] != 0.0:
        run += 1
        j -= 1
    j = e + 1
    while run < need and j <= last and ring[j % m, R_RAW] != 0.0:
        run += 1
        j += 1
    return run >= need


@njit(cache=True)
def _emit(ring: np.ndarray, e: int, zv: bool, k: int, out_t: np.ndarray, out_acc: np.ndarray,
          out_gyro: np.ndarray, out_zv: np.ndarray, out_stat: np.ndarray) -> None:
    r = e % ring.shape[0]
    out_t[k] = ring[r, R_T]
    for i in range(3):
        out_acc[k, i] = ring[r, R_ACC + i]
        out_gyro[k, i] = ring[r, R_GYRO + i]
    out_zv[k] = zv
    out_stat[k, 0] = ring[r, R_STAT]
    out_stat[k, 1] = ring[r, R_THR]
    out_stat[k, 2] = ring[r, R_MODE]


@njit(cache=True, nogil=True)  # releases the GIL: firefighters run on worker threads
def detect(t: np.ndarray, acc: np.ndarray, gyro: np.ndarray, ring: np.ndarray,
           ist: np.ndarray, dq: np.ndarray, cfg: DetectorConfig, out_t: np.ndarray, out_acc: np.ndarray,
           out_gyro: np.ndarray, out_zv: np.ndarray, out_stat: np.ndarray) -> int:
    """Feed samples; write the samples whose decision is final (oldest first); return how many.

    Output arrays need room for ``len(t)`` rows; ``out_stat`` (n, 3) receives log10 T of
    each sample, the log10 threshold it was compared with and the gait mode (``MODE_*``).
    """
    m = ring.shape[0]
    h = cfg.window // 2
    raw_lag = h + (cfg.ahead if cfg.kind == ADAPTIVE else 0)
    run_lag = _longest_run(cfg) - 1
    k = 0
    for i in range(t.shape[0]):
        n = ist[D_N_IN]
        r = n % m
        ring[r, R_T] = t[i]
        for c in range(3):
            ring[r, R_ACC + c] = acc[i, c]
            ring[r, R_GYRO + c] = gyro[i, c]
        ist[D_N_IN] = n + 1
        c = n - h
        if c >= 0:
            ring[c % m, R_STAT], ring[c % m, R_UP] = _statistic(ring, max(0, c - h), n, cfg)
            if cfg.kind == ADAPTIVE:
                _push(ring, ist, dq, c)
        d = c - (raw_lag - h)
        if d >= 0:
            _raw_decision(ring, ist, dq, d, cfg)
        e = d - run_lag
        if e >= 0:
            _emit(ring, e, _final_decision(ring, e, d, cfg), k, out_t, out_acc, out_gyro,
                  out_zv, out_stat)
            k += 1
            ist[D_N_OUT] = e + 1
    return k


@njit(cache=True, nogil=True)  # releases the GIL: firefighters run on worker threads
def flush(ring: np.ndarray, ist: np.ndarray, dq: np.ndarray, cfg: DetectorConfig,
          out_t: np.ndarray,
          out_acc: np.ndarray, out_gyro: np.ndarray, out_zv: np.ndarray,
          out_stat: np.ndarray) -> int:
    """Decide the samples still waiting for look-ahead at the end of the input."""
    m = ring.shape[0]
    h = cfg.window // 2
    raw_lag = h + (cfg.ahead if cfg.kind == ADAPTIVE else 0)
    n = ist[D_N_IN]
    last = n - 1
    for c in range(max(0, n - h), n):
        ring[c % m, R_STAT], ring[c % m, R_UP] = _statistic(ring, max(0, c - h), last, cfg)
        if cfg.kind == ADAPTIVE:
            _push(ring, ist, dq, c)
    for d in range(max(0, n - raw_lag), n):
        _raw_decision(ring, ist, dq, d, cfg)
    k = 0
    for e in range(ist[D_N_OUT], n):
        _emit(ring, e, _final_decision(ring, e, last, cfg), k, out_t, out_acc, out_gyro,
              out_zv, out_stat)
        k += 1
    ist[D_N_OUT] = n
    return k
