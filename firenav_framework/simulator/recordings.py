"""What a foot-IMU recording holds, and how a track made from it drifts in heading.

Used to hold the simulator against the real recordings of ``../shared/data``
(``benchmarks/bench_sim_realism.py``, ``tests/sim``): the VICON set mixes walking at
several paces, running, crawling and motion in place without saying which trial is
which; :func:`classify_recording` works it out from the data alone, the same way for a
real trial and for a simulated one.

How (one figure each, all from the IMU except the pace):

* **crawl**: at rest the foot is upside down (the specific force of the low-rate samples
  points more than 90 degrees away from the walking foot's "up"): the shoe lies on its
  top, as on hands and knees;
* **in place**: the foot moves (peak rates of tens of deg/s, lifted up to a metre) but
  travels in under 20 % of the seconds (a 1-s step of the position over 0.2 m);
* **run**: strides faster than 1.15 Hz (the gyro's dominant frequency; walking: 0.6-1 Hz)
  and peaks above 4 g (the 99th percentile of the specific force; walking: 2-3.5 g);
* **walk** otherwise, by pace (the foot's path length over the time from its first to its
  last move): slow below 0.7 m/s, brisk above 1.2 m/s, normal in between.

:func:`heading_drift` fits the heading error of a track at its steps (the direction of
each step against the truth's) with a drift rate and a share of the angle turned (the
gyro's scale factor shows as heading error per degree turned).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import welch

__all__ = ["RecordingClass", "classify_recording", "HeadingFit", "heading_drift",
           "walking_speed"]

#: Thresholds of :func:`classify_recording` (see the module docstring).
SLOW_MPS, BRISK_MPS = 0.7, 1.2
RUN_STRIDE_HZ, RUN_PEAK_G = 1.15, 4.0
IN_PLACE_TRAVEL = 0.2
G0 = 9.80665


@dataclass(frozen=True)
class RecordingClass:
    """``kind``: ``walk``, ``run``, ``crawl`` or ``in_place``; ``pace``: ``slow``,
    ``normal`` or ``brisk`` for walks (else ""); the figures it was decided on: median
    travelling speed [m/s], share of 1-s steps that travel, stride frequency [Hz],
    99th-percentile specific force [g], and whether the foot rests upside down."""

    kind: str
    pace: str
    speed_mps: float
    travelling: float
    stride_hz: float
    peak_g: float
    upside_down: bool

    @property
    def label(self) -> str:
        """``walk_slow``, ``walk_normal``, ``walk_brisk``, ``run``, ``crawl``, ``in_place``."""
        return f"{self.kind}_{self.pace}" if self.pace else self.kind


def walking_speed(t: np.ndarray, position: np.ndarray) -> tuple[float, float]:
    """(pace [m/s], travelling share) of a foot track ``position`` (N, >=2) [m] at ``t``.

    Pace: the horizontal path length (sampled every 0.2 s) over the time from the first
    to the last 0.2-s step faster than 0.3 m/s; travelling share: the share of 1-s steps
    longer than 0.2 m.
    """
    t = np.asarray(t, float)
    pos = np.asarray(position, float)
    dt = float(np.median(np.diff(t)))
    k = max(1, int(round(0.2 / dt)))
    d = np.linalg.norm(np.diff(pos[::k, :2], axis=0), axis=1)
    moving = np.flatnonzero(d > 0.3 * k * dt)
    pace = float(d.sum() / ((moving[-1] - moving[0] + 1) * k * dt)) if len(moving) else 0.0
    step = max(1, int(round(1.0 / dt)))
    v = np.linalg.norm(pos[step::step, :2] - pos[:-step:step, :2], axis=1)
    return pace, float(np.mean(v > 0.2)) if len(v) else 0.0


def classify_recording(t: np.ndarray, accel: np.ndarray, gyro: np.ndarray,
                       position: np.ndarray, up_axis: np.ndarray) -> RecordingClass:
    """Classify a foot-IMU recording: ``t`` (N,) [s], ``accel`` (N, 3) [m/s^2], ``gyro``
    (N, 3) [rad/s] in device axes, ``position`` (N, >=2) [m] of the foot (truth), and
    ``up_axis`` (3,): the device axis that points up when the foot stands flat (e.g.
    ``[0, 0, -1]`` for a z-down unit)."""
    t = np.asarray(t, float)
    accel = np.asarray(accel, float)
    gyro = np.asarray(gyro, float)
    if len(t) < 200 or accel.shape != (len(t), 3) or gyro.shape != (len(t), 3):
        raise ValueError(f"need at least 200 samples of t (N,), accel and gyro (N, 3); got "
                         f"{t.shape}, {accel.shape}, {gyro.shape}")
    fs = 1.0 / float(np.median(np.diff(t)))
    rate = np.degrees(np.linalg.norm(gyro, axis=1))
    quiet = rate < 20.0
    rest = accel[quiet].mean(axis=0) if quiet.any() else accel.mean(axis=0)
    upside_down = float(rest @ np.asarray(up_axis, float)) < 0.0
    speed, travelling = walking_speed(t, position)
    f, p = welch(rate - rate.mean(), fs=fs, nperseg=min(len(rate), int(20 * fs)))
    band = (f > 0.4) & (f < 2.2)
    stride_hz = float(f[band][np.argmax(p[band])]) if band.any() else 0.0
    peak_g = float(np.percentile(np.linalg.norm(accel, axis=1), 99)) / G0
    pace = ""
    if upside_down:
        kind = "crawl"
    elif travelling < IN_PLACE_TRAVEL:
        kind = "in_place"
    elif stride_hz > RUN_STRIDE_HZ and peak_g > RUN_PEAK_G:
        kind = "run"
    else:
        kind = "walk"
        pace = "slow" if speed < SLOW_MPS else ("brisk" if speed > BRISK_MPS else "normal")
    return RecordingClass(kind, pace, speed, travelling, stride_hz, peak_g, upside_down)


@dataclass(frozen=True)
class HeadingFit:
    """Heading error of a track at its steps.

    ``drift_dps`` [deg/s]: slope of the error over time (``e = e0 + drift t``);
    ``turn_pct`` [%]: heading error per angle turned, with the drift fitted beside it
    (``e = e0 + d t + k turn``); ``rms_deg``: what the drift fit leaves [deg]; ``steps``:
    steps used; ``duration_s``.
    """

    drift_dps: float
    turn_pct: float
    rms_deg: float
    steps: int
    duration_s: float


def heading_drift(est: np.ndarray, truth: np.ndarray, t: np.ndarray, *, n_align: int = 5,
                  min_step_m: float = 0.3) -> HeadingFit:
    """Fit the heading error of the steps of ``est`` against ``truth`` (K, >=2) [m] at
    times ``t`` (K,) [s].

    The direction of each step (from one point to the next) is compared with the
    truth's; steps shorter than ``min_step_m`` in the truth are left out (turning on the
    spot); the error is taken relative to its median over the first ``n_align`` steps
    (the unknown start heading), unwrapped, and fitted by least squares against time and
    the angle the truth has turned since the start (see :class:`HeadingFit`).
    """
    est = np.asarray(est, float)[:, :2]
    truth = np.asarray(truth, float)[:, :2]
    t = np.asarray(t, float)
    if est.shape != truth.shape or len(t) != len(est):
        raise ValueError(f"need est, truth (K, 2) and t (K,) of one length; got {est.shape}, "
                         f"{truth.shape}, {t.shape}")
    de, dt_ = np.diff(est, axis=0), np.diff(truth, axis=0)
    keep = np.hypot(*dt_.T) >= min_step_m
    if keep.sum() < n_align + 3:
        nan = float("nan")
        return HeadingFit(nan, nan, nan, int(keep.sum()), float(t[-1] - t[0]) if len(t) else nan)
    he = np.unwrap(np.arctan2(de[keep, 1], de[keep, 0]))
    ht = np.unwrap(np.arctan2(dt_[keep, 1], dt_[keep, 0]))
    err = np.degrees(np.unwrap(he - ht))
    err -= np.median(err[:n_align])
    tm = t[1:][keep]
    turn = np.degrees(ht - ht[0])
    a = np.column_stack([np.ones_like(tm), tm - tm[0]])
    line, *_ = np.linalg.lstsq(a, err, rcond=None)
    both, *_ = np.linalg.lstsq(np.column_stack([a, turn]), err, rcond=None)
    resid = err - a @ line
    return HeadingFit(float(line[1]), float(100.0 * both[2]), float(np.sqrt(np.mean(resid ** 2))),
                      int(keep.sum()), float(tm[-1] - tm[0]))
