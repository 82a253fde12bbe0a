"""Sample screening of one IMU stream: what is dropped, what is flagged, and counts.

Rules, applied to one device's samples in arrival order (SI units, device axes,
before calibration; all array operations):

``nonfinite``
    NaN or infinite time, accel or gyro: dropped.
``out_of_range``
    any accel or gyro component beyond the physically plausible limit: dropped (a
    reading no foot IMU can produce is a corrupt one).
``time_outlier``
    a single sample whose time leaps forward by more than ``gap`` while the next
    sample returns to just after its predecessor: a corrupt timestamp, dropped
    (without this, every later sample would look like it went back in time).
``duplicate``
    same time and same accel+gyro values as a sample already kept (this block or
    the last :data:`MEMORY` samples of the device): dropped.
``time_backwards``
    time not after the newest sample kept so far (and not a duplicate): dropped.
``saturated``
    a component at or beyond the device's full scale (if given), or flagged so by
    the device or decoder: kept, flag bit ``saturated``.
``gap``
    a step between consecutive kept samples longer than ``gap``: kept, the sample
    after the gap gets the flag bit ``gap_before``.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numba import njit
from pydantic import model_validator

from firenav_framework.contract import Params, param
from firenav_framework.messages import IMU_FLAG_BITS

__all__ = ["ScreeningLimits", "DeviceHistory", "Screening", "screen", "MEMORY", "COUNTS"]

#: Kept samples per device remembered for duplicate detection across blocks.
MEMORY = 64

#: The counts a :class:`Screening` reports, in the order they are applied.
COUNTS = ("nonfinite", "out_of_range", "time_outlier", "duplicate", "time_backwards",
          "saturated", "gaps")

SATURATED = np.uint8(IMU_FLAG_BITS["saturated"])
GAP_BEFORE = np.uint8(IMU_FLAG_BITS["gap_before"])


class ScreeningLimits(Params):
    """Thresholds of the screening (the ``screening`` parameter group), SI units."""

    accel_range: float = param(400.0, unit="m/s^2", gt=0)
    """plausible limit per axis (about 40 g); samples beyond are dropped as corrupt"""
    gyro_range: float = param(40.0, unit="rad/s", gt=0)
    """plausible limit per axis (about 2300 deg/s); samples beyond are dropped"""
    accel_saturation: float | None = param(None, unit="m/s^2", gt=0)
    """the device's accel full scale: samples at or beyond are flagged saturated and kept"""
    gyro_saturation: float | None = param(None, unit="rad/s", gt=0)
    """the device's gyro full scale (flag, keep)"""
    gap: float = param(0.05, unit="s", gt=0)
    """a step between samples longer than this is a gap: flagged gap_before, counted and reported"""

    @model_validator(mode="after")
    def _saturation_in_range(self) -> "ScreeningLimits":
        for kind in ("accel", "gyro"):
            sat, rng = getattr(self, f"{kind}_saturation"), getattr(self, f"{kind}_range")
            if sat is not None and sat > rng:
                raise ValueError(f"{kind}_saturation ({sat}) must not exceed "
                                 f"{kind}_range ({rng}): saturated samples would be dropped")
        return self


@dataclass
class DeviceHistory:
    """What screening remembers of one device between blocks: its last kept samples."""

    times: np.ndarray = field(default_factory=lambda: np.empty(0))
    values: np.ndarray = field(default_factory=lambda: np.empty((0, 6)))

    @property
    def last_t(self) -> float:
        return float(self.times[-1]) if len(self.times) else -np.inf


@dataclass(frozen=True)
class Screening:
    """Result of :func:`screen`: which input samples to keep, their flags, counts."""

    keep: np.ndarray          # (N,) bool over the input samples
    flags: np.ndarray         # (kept,) uint8 IMU_FLAG_BITS
    counts: dict[str, int]    # by the names in COUNTS
    longest_gap: float        # s, 0 when there was none


def screen(time: np.ndarray, accel: np.ndarray, gyro: np.ndarray, limits: ScreeningLimits,
           history: DeviceHistory, flags: np.ndarray | None = None) -> Screening:
    """Screen one device's samples (see the module docstring); updates ``history``.

    ``time`` (N,) [s], ``accel`` (N, 3) [m/s^2], ``gyro`` (N, 3) [rad/s] in arrival
    order; ``flags`` (N,) uint8 flags already set upstream (kept and extended).
    """
    values = np.hstack((accel, gyro))
    if _clean(time, values, history.last_t, limits.accel_range, limits.gyro_range,
              limits.gap, limits.accel_saturation or np.inf, limits.gyro_saturation or np.inf):
        return _all_kept(time, values, history, flags)
    return apply_rules(time, accel, gyro, limits, history, flags)


def apply_rules(time: np.ndarray, accel: np.ndarray, gyro: np.ndarray,
                limits: ScreeningLimits, history: DeviceHistory,
                flags: np.ndarray | None = None) -> Screening:
    """Every rule of the module docstring, as arrays (:func:`screen` skips this for
    samples that none of them concerns, the common case)."""
    n = len(time)
    values = np.hstack((accel, gyro))
    finite = np.isfinite(time) & np.isfinite(values).all(axis=1)
    with np.errstate(invalid="ignore"):
        in_range = ((np.abs(accel) <= limits.accel_range).all(axis=1)
                    & (np.abs(gyro) <= limits.gyro_range).all(axis=1))
    cand = np.flatnonzero(finite & in_range)

    last_t = history.last_t
    t = time[cand]
    prev = np.concatenate(([last_t], t))[:-1]
    nxt = np.concatenate((t, [np.inf]))[1:]
    outlier = np.isfinite(prev) & (t - prev > limits.gap) & (nxt > prev) & (nxt < t)
    cand, t = cand[~outlier], t[~outlier]

    newest_before = np.maximum.accumulate(np.concatenate(([last_t], t)))[:-1]
    forward = t > newest_before
    kept, late = cand[forward], cand[~forward]

    ref_t = np.concatenate((history.times, time[kept]))
    ref_v = np.concatenate((history.values, values[kept]))
    duplicate = np.zeros(len(late), bool)
    if len(late) and len(ref_t):
        pos = np.minimum(np.searchsorted(ref_t, time[late]), len(ref_t) - 1)
        duplicate = (ref_t[pos] == time[late]) & (ref_v[pos] == values[late]).all(axis=1)

    tk = time[kept]
    dt = np.diff(np.concatenate(([last_t], tk)))
    gap_before = dt > limits.gap
    if len(gap_before) and not np.isfinite(last_t):
        gap_before[0] = False  # the first sample of a device follows nothing
    saturated = np.zeros(len(kept), bool)
    if limits.accel_saturation is not None:
        saturated |= (np.abs(accel[kept]) >= limits.accel_saturation).any(axis=1)
    if limits.gyro_saturation is not None:
        saturated |= (np.abs(gyro[kept]) >= limits.gyro_saturation).any(axis=1)
    out_flags = (np.zeros(len(kept), np.uint8) if flags is None
                 else np.asarray(flags, np.uint8)[kept].copy())
    out_flags[saturated] |= SATURATED
    out_flags[gap_before] |= GAP_BEFORE

    if len(kept):
        history.times = ref_t[-MEMORY:]
        history.values = ref_v[-MEMORY:]
    keep = np.zeros(n, bool)
    keep[kept] = True
    counts = {
        "nonfinite": int(n - finite.sum()),
        "out_of_range": int((finite & ~in_range).sum()),
        "time_outlier": int(outlier.sum()),
        "duplicate": int(duplicate.sum()),
        "time_backwards": int(len(late) - duplicate.sum()),
        "saturated": int(((out_flags & SATURATED) != 0).sum()),
        "gaps": int(gap_before.sum()),
    }
    return Screening(keep=keep, flags=out_flags, counts=counts,
                     longest_gap=float(dt[gap_before].max()) if gap_before.any() else 0.0)


@njit(cache=True, nogil=True)
def _clean(time: np.ndarray, values: np.ndarray, last_t: float, accel_range: float,
           gyro_range: float, gap: float, accel_sat: float, gyro_sat: float) -> bool:
    """Whether no rule applies to any sample: all finite, within range and below full
    scale, times strictly increasing from ``last_t`` with no step longer than ``gap``
    (the first sample of a device, after ``last_t = -inf``, follows nothing)."""
    prev = last_t
    for i in range(len(time)):
        t = time[i]
        if not np.isfinite(t) or not t > prev or (np.isfinite(prev) and t - prev > gap):
            return False
        for j in range(6):
            v = values[i, j]
            if not np.isfinite(v) or abs(v) > (accel_range if j < 3 else gyro_range) \
                    or abs(v) >= (accel_sat if j < 3 else gyro_sat):
                return False
        prev = t
    return True


def _all_kept(time: np.ndarray, values: np.ndarray, history: DeviceHistory,
              flags: np.ndarray | None) -> Screening:
    """The screening of samples :func:`_clean` passed: all kept, nothing counted."""
    n = len(time)
    if n:
        history.times = np.concatenate((history.times, time))[-MEMORY:]
        history.values = np.concatenate((history.values, values))[-MEMORY:]
    out_flags = np.zeros(n, np.uint8) if flags is None else np.array(flags, np.uint8)
    counts = dict.fromkeys(COUNTS, 0)
    if flags is not None and out_flags.any():   # flagged saturated by the device or codec
        counts["saturated"] = int(np.count_nonzero(out_flags & SATURATED))
    return Screening(keep=np.ones(n, bool), flags=out_flags, counts=counts, longest_gap=0.0)
