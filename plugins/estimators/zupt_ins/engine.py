"""The ZUPT-aided INS as a streaming engine over arrays: detector -> filter -> steps.

:class:`InsEngine` is what the estimator and the benchmarks call. Feed it
blocks of samples (time [s], specific force and angular rate in the FLU body frame)
with :meth:`InsEngine.process`; call :meth:`InsEngine.finish` at the end of the
recording. Everything it carries between calls is arrays, so the result of a recording
does not depend on how it was cut into blocks.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from . import detectors, eskf


@dataclass
class BlockResult:
    """What one call produced.

    ``states`` (N, eskf.N_OUT): full-rate filter output of the samples processed in this
    call (columns ``eskf.O_*``); ``stat`` (N, 3) log10 of the detector statistic, of the
    threshold it was compared with, and the detector's gait mode (``detectors.MODE_*``);
    ``events`` (M, eskf.N_EVENT): step/still events (columns ``eskf.E_*``).
    """

    states: np.ndarray
    stat: np.ndarray
    events: np.ndarray

    @staticmethod
    def empty() -> "BlockResult":
        return BlockResult(np.zeros((0, eskf.N_OUT)), np.zeros((0, 3)), np.zeros((0, eskf.N_EVENT)))

    @staticmethod
    def concat(parts: list["BlockResult"]) -> "BlockResult":
        if not parts:
            return BlockResult.empty()
        return BlockResult(np.concatenate([p.states for p in parts]),
                           np.concatenate([p.stat for p in parts]),
                           np.concatenate([p.events for p in parts]))


@dataclass
class InsEngine:
    """Detector and filter state of one IMU (one foot of one firefighter)."""

    detector: detectors.DetectorConfig
    filter: eskf.FilterConfig
    _det: tuple = field(init=False, repr=False)
    _filt: tuple = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self._det = detectors.new_state(self.detector)
        self._filt = eskf.new_state(self.filter)

    # -- state -------------------------------------------------------------------------
    @property
    def aligned(self) -> bool:
        return bool(self._filt[2][eskf.I_ALIGNED])

    @property
    def alignment_samples(self) -> int:
        """Still samples the alignment averaged (fewer than configured after a fallback)."""
        return int(self._filt[2][eskf.I_ALIGN_N])

    @property
    def gaps(self) -> int:
        """Sample intervals longer than ``max_dt`` (integrated as max_dt)."""
        return int(self._filt[2][eskf.I_GAPS])

    @property
    def zaru_rejected(self) -> int:
        """Zero angular rate updates refused by the innovation gate."""
        return int(self._filt[2][eskf.I_ZARU_REJECTED])

    @property
    def nominal(self) -> np.ndarray:
        """Copy of the nominal state (p, v, q, ba, bg)."""
        return self._filt[0].copy()

    @property
    def covariance(self) -> np.ndarray:
        """Copy of the error-state covariance (see eskf module docstring for the layout)."""
        return self._filt[1].copy()

    @property
    def samples_in(self) -> int:
        return int(self._det[2][detectors.D_N_IN])

    # -- processing --------------------------------------------------------------------
    def process(self, t: np.ndarray, acc: np.ndarray, gyro: np.ndarray) -> BlockResult:
        """Feed samples (already checked: finite, increasing time); returns what is done."""
        n = len(t)
        if n == 0:
            return BlockResult.empty()
        buf = _buffers(n)
        k = detectors.detect(np.ascontiguousarray(t, dtype=float),
                             np.ascontiguousarray(acc, dtype=float),
                             np.ascontiguousarray(gyro, dtype=float),
                             *self._det, self.detector, *buf)
        return self._filter(buf, k)

    def finish(self) -> BlockResult:
        """Process the samples still waiting for the detector's look-ahead, and a step
        still waiting to settle in its stance."""
        buf = _buffers(detectors.lookahead(self.detector) + 1)
        k = detectors.flush(*self._det, self.detector, *buf)
        res = self._filter(buf, k)
        last = np.empty((1, eskf.N_EVENT))
        if eskf.finish_filter(*self._filt, self.filter, last):
            res.events = np.concatenate((res.events, last))
        return res

    def _filter(self, buf: tuple, k: int) -> BlockResult:
        t, acc, gyro, zv, stat = (b[:k] for b in buf)
        out = np.empty((k, eskf.N_OUT))
        events = np.empty((k, eskf.N_EVENT))
        n_ev = eskf.run_filter(t, acc, gyro, zv, *self._filt, self.filter, out, events)
        return BlockResult(out, stat.copy(), events[:n_ev].copy())


def _buffers(n: int) -> tuple[np.ndarray, ...]:
    return (np.empty(n), np.empty((n, 3)), np.empty((n, 3)), np.empty(n, np.bool_), np.empty((n, 3)))
