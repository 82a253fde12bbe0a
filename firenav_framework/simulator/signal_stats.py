"""Statistics of a foot IMU's signals around ground contact, real or simulated.

What makes stance detection and zero-velocity updates hard is how the signals behave
between two swings: how low the angular rate gets and for how long, how the rate
decays after heel strike and rises towards toe-off, how the mount rings after the
impact. :func:`stance_statistics` measures that on any recording (device axes do not
matter: only vector norms are used), so the simulator can be held against the real
data in ``../shared/data`` (``benchmarks/bench_sim_realism.py``, ``tests/sim``).

Per gait cycle (between two swings, each with a rate above ``swing_dps``):

* ``floor_dps``: the lowest angular rate, smoothed over 25 ms (the usual detector
  window);
* ``below_dps``: time [s] per cycle with the smoothed rate below 20, 50 and 100 deg/s;
* ``strike_to_min_s``: from heel strike (the steepest change of the specific-force
  magnitude within 45 % of a cycle before the rate minimum) to the minimum;
* ``ring_acc`` / ``ring_gyro``: rms of the high-passed (> 10 Hz) specific force
  [m/s^2] / angular rate [deg/s] from 25 to 150 ms after heel strike (impact ringing
  and the foot slap);
* ``impact_g``: largest specific-force magnitude around heel strike [g];
* ``cycle_s``: the gait cycle (minimum to minimum).

Standing (runs of at least 1.5 s without any rate above 5 deg/s): ``stand_dps``, the
rms angular rate after removing each run's mean (postural sway and noise).

Where the true position of the IMU is known (VICON, the simulator),
:func:`quiet_displacement` measures how far the IMU still moves while its angular rate
stays low: what a zero-velocity update there throws away.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import uniform_filter1d
from scipy.signal import butter, find_peaks, sosfiltfilt

G0 = 9.80665
THRESHOLDS_DPS = (20.0, 50.0, 100.0)


@dataclass
class StanceStatistics:
    """Per-cycle figures (arrays over the detected gait cycles) and standing figures."""

    floor_dps: np.ndarray
    below_dps: np.ndarray           # (n, 3): time below THRESHOLDS_DPS [s]
    strike_to_min_s: np.ndarray
    ring_acc: np.ndarray
    ring_gyro: np.ndarray
    impact_g: np.ndarray
    cycle_s: np.ndarray
    stand_dps: np.ndarray           # one per standing run

    @property
    def cycles(self) -> int:
        return len(self.floor_dps)

    def summary(self) -> dict[str, float]:
        """Medians over the cycles (NaN where there are none)."""
        def med(x):
            return float(np.median(x)) if len(x) else float("nan")
        out = {"cycles": float(self.cycles), "cycle_s": med(self.cycle_s),
               "floor_dps": med(self.floor_dps)}
        for i, th in enumerate(THRESHOLDS_DPS):
            out[f"below_{th:.0f}_s"] = med(self.below_dps[:, i]) if self.cycles else float("nan")
        out.update({"strike_to_min_s": med(self.strike_to_min_s), "ring_acc": med(self.ring_acc),
                    "ring_gyro": med(self.ring_gyro), "impact_g": med(self.impact_g),
                    "stand_dps": med(self.stand_dps)})
        return out


def true_runs(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start and end (exclusive) index of every run of True in a boolean array."""
    edges = np.diff(np.concatenate([[0], np.asarray(mask, bool).astype(np.int8), [0]]))
    return np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)


def _valleys(rate_dps: np.ndarray, fs: float, swing_dps: float) -> np.ndarray:
    """Sample index of the rate minimum of every stance between two swings."""
    coarse = np.log10(uniform_filter1d(rate_dps, max(1, int(0.2 * fs))) + 1.0)
    cand, _ = find_peaks(-coarse, distance=max(1, int(0.6 * fs)), prominence=0.6)
    fine = uniform_filter1d(rate_dps, max(1, int(round(0.025 * fs))))
    half, sec = int(0.15 * fs), int(fs)
    out = []
    for i in cand:
        a, b = max(0, i - half), min(len(fine), i + half)
        j = a + int(np.argmin(fine[a:b]))
        if j > 0 and rate_dps[max(0, j - sec):j].max(initial=0) > swing_dps \
                and rate_dps[j:j + sec].max(initial=0) > swing_dps:
            out.append(j)
    return np.unique(np.array(out, int))


def _standing(rate_dps: np.ndarray, gyro_dps: np.ndarray, fs: float) -> np.ndarray:
    quiet = uniform_filter1d((rate_dps > 5.0).astype(float), max(1, int(0.5 * fs))) == 0
    out = []
    for a, b in zip(*true_runs(quiet)):
        if b - a >= 1.5 * fs:
            x = gyro_dps[a:b] - gyro_dps[a:b].mean(axis=0)
            out.append(float(np.sqrt(np.mean(np.sum(x * x, axis=1)))))
    return np.array(out)


def stance_statistics(t: np.ndarray, accel: np.ndarray, gyro: np.ndarray,
                      swing_dps: float = 150.0) -> StanceStatistics:
    """Measure a recording: ``t`` (N,) [s] at a constant rate, ``accel`` (N, 3)
    [m/s^2], ``gyro`` (N, 3) [rad/s] in any (fixed) device axes."""
    t = np.asarray(t, float)
    accel = np.asarray(accel, float)
    gyro_dps = np.degrees(np.asarray(gyro, float))
    if len(t) < 10 or accel.shape != (len(t), 3) or gyro_dps.shape != (len(t), 3):
        raise ValueError(f"need N >= 10 samples of t (N,), accel and gyro (N, 3); got "
                         f"{t.shape}, {accel.shape}, {gyro_dps.shape}")
    fs = 1.0 / float(np.median(np.diff(t)))
    rate = np.linalg.norm(gyro_dps, axis=1)
    fine = uniform_filter1d(rate, max(1, int(round(0.025 * fs))))
    f_norm = np.linalg.norm(accel, axis=1)
    sos = butter(4, 10.0, "highpass", fs=fs, output="sos")
    hp_acc = np.linalg.norm(sosfiltfilt(sos, accel, axis=0), axis=1)
    hp_gyro = np.linalg.norm(sosfiltfilt(sos, gyro_dps, axis=0), axis=1)
    v = _valleys(rate, fs, swing_dps)
    n = len(t)
    rows = []
    for i, j in enumerate(v):
        lo = (v[i - 1] + j) // 2 if i > 0 else None
        hi = (j + v[i + 1]) // 2 if i + 1 < len(v) else None
        if lo is None or hi is None:
            continue
        # heel strike: in the late swing or after it, up to 45 % of a cycle before the
        # minimum (the minimum comes about a quarter cycle after heel strike)
        a = int(j - 0.45 * (v[i + 1] - v[i - 1]) / 2)
        if a < 1:
            continue
        seg = fine[lo:hi]
        below = [np.count_nonzero(seg < th) / fs for th in THRESHOLDS_DPS]
        hs = a + int(np.argmax(np.abs(np.diff(f_norm[a - 1:j - int(0.02 * fs)]))))
        r0, r1 = hs + int(0.025 * fs), hs + int(0.150 * fs)
        if r1 >= n:
            continue
        rows.append((fine[j], *below, (j - hs) / fs,
                     float(np.sqrt(np.mean(hp_acc[r0:r1] ** 2))),
                     float(np.sqrt(np.mean(hp_gyro[r0:r1] ** 2))),
                     f_norm[max(0, hs - int(0.025 * fs)):hs + int(0.05 * fs)].max() / G0,
                     (v[i + 1] - v[i - 1]) / (2 * fs)))
    r = np.array(rows, float).reshape(-1, 9)
    return StanceStatistics(floor_dps=r[:, 0], below_dps=r[:, 1:4], strike_to_min_s=r[:, 4],
                            ring_acc=r[:, 5], ring_gyro=r[:, 6], impact_g=r[:, 7],
                            cycle_s=r[:, 8], stand_dps=_standing(rate, gyro_dps, fs))


def quiet_displacement(t: np.ndarray, gyro: np.ndarray, position: np.ndarray,
                       below_dps: float = 20.0) -> np.ndarray:
    """Horizontal displacement [m] of the IMU over every quiet interval: a run of 40 ms
    to 1 s with the angular rate (smoothed over 25 ms) below ``below_dps``.

    ``t`` (N,) [s], ``gyro`` (N, 3) [rad/s], ``position`` (N, >=2) [m] of the IMU.
    """
    t = np.asarray(t, float)
    position = np.asarray(position, float)
    if position.ndim != 2 or len(position) != len(t) or position.shape[1] < 2 or len(t) < 10:
        raise ValueError(f"need N >= 10 times and positions (N, 2 or 3); got {t.shape}, "
                         f"{position.shape}")
    fs = 1.0 / float(np.median(np.diff(t)))
    rate = uniform_filter1d(np.degrees(np.linalg.norm(np.asarray(gyro, float), axis=1)),
                            max(1, int(round(0.025 * fs))))
    starts, ends = true_runs(rate < below_dps)
    ends = ends - 1                                   # last quiet sample
    keep = (ends - starts >= 0.04 * fs) & (ends - starts <= fs)
    starts, ends = starts[keep], ends[keep]
    return np.linalg.norm(position[ends, :2] - position[starts, :2], axis=1)
