"""The two real foot-IMU datasets in ``../shared/data`` (MATLAB ``.mat`` files).

Both come from the ``gait-driven-inertial-navigation-dataset`` collection (see the
data README) and hold a MicroStrain 3DM-GX5 foot IMU at 200 Hz in its own sensor
frame, z axis down (specific force about -9.8 m/s^2 on z at rest): the
``foot_imu`` sensor maps it to FLU with ``axes: [x, -y, -z]``.

``pyshoe-vicon/<date>.mat`` (UTIAS PyShoe, 56 trials)
    ``ts``, ``imu``, ``gt`` (VICON foot position at every sample), zero-velocity
    labels of five detectors. :func:`load_vicon_trial`.
PyShoe's hallway and stair trials (``processed_data.mat``: ``imu``, ``gt``, ``gt_idx``)
    sparse truth at the samples ``gt_idx``: :func:`read_pyshoe_sparse`.
``indoor-walks/walk_<n>.mat`` (self-collected building walks)
    ``timestamps``, ``imu_data``, ``strideIndex`` + ``GCP`` (surveyed footprint at
    each stride: the ground truth) and ``pyshoeTrajectory`` (PyShoe's LSTM-aided INS
    on the same data: a reference solution). :func:`load_indoor_walk`.

The array loaders are the stable API for benchmarks; the ``.mat`` reader turns
either file into messages for the ``recording`` source:

* port ``imu``: :class:`ImuBlock` pieces of ``block_s``, ``frame="device"``, as recorded;
* port ``truth``: :class:`GroundTruth` -- VICON positions decimated to 20 Hz, in the
  **VICON frame** (origin and axes of the capture area, z up, not ENU of any
  building); or the indoor walks' GCP footprints (z = 0) at each stride time;
* port ``reference`` (indoor walks only): the stored ``pyshoeTrajectory`` as
  :class:`PoseEstimate` at 20 Hz (z = 0, heading and covariance unknown: NaN).

Frames: neither truth shares the INS frame (its yaw is not observable), so compare
after aligning the start (see the data README). GCP and ``pyshoeTrajectory`` are
roughly in the same axes already: the best-fit rotation between them is under 3.5
degrees on walks 31-36 and 8-15 degrees on walks 37-38.
"""
from __future__ import annotations

import heapq
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...messages import GroundTruth, Message, PoseEstimate
from ...formats.base import ReaderError, ReadOptions, imu_blocks

__all__ = ["ViconTrial", "IndoorWalk", "load_vicon_trial", "load_indoor_walk",
           "read_vicon_trial", "read_indoor_walk", "read_pyshoe_sparse", "read_mat",
           "VICON_DETECTORS",
           "vicon_motion", "VICON_MOTIONS"]

#: Detector names of the ``zv_<det>_opt`` / ``G_<det>_opt`` variables, in the order
#: that ``trial_error`` most likely follows (consistent with ``best_detector`` and
#: ``best_error`` in all 56 trials; ``ared``/``amvd`` cannot be told apart that way).
VICON_DETECTORS = ("shoe", "ared", "amvd", "mbgtd", "vicon")

#: The files' horizontal truth (VICON ``gt`` x, y; the walks' ``GCP`` and
#: ``pyshoeTrajectory``) is the mirror image of an ENU frame: PyShoe navigates z-down
#: and compares x, y by rotation only. The loaders multiply the stored x, y by this, so
#: the arrays and messages they give are right-handed ENU (z up) and a rotation plus a
#: translation aligns them with any INS track. Without it every turn would go the wrong way.
ENU_FROM_DATASET_XY = np.array([1.0, -1.0])

#: Rate [Hz] at which dense truth and reference trajectories are published.
TRAJECTORY_RATE_HZ = 20.0

_VICON_KEYS = ("ts", "imu", "gt")
_WALK_KEYS = ("timestamps", "imu_data", "strideIndex", "GCP")


class _ImuColumns:
    """``accel`` and ``gyro`` views of an ``imu`` (N, 6) array: specific force [m/s^2]
    then angular rate [rad/s], device frame."""

    imu: np.ndarray

    @property
    def accel(self) -> np.ndarray:
        """(N, 3) specific force [m/s^2], device frame."""
        return self.imu[:, :3]

    @property
    def gyro(self) -> np.ndarray:
        """(N, 3) angular rate [rad/s], device frame."""
        return self.imu[:, 3:]


@dataclass(frozen=True)
class ViconTrial(_ImuColumns):
    """One PyShoe VICON trial as arrays.

    ``ts`` (N,) sample times [s] (start near 0); ``imu`` (N, 6) specific force
    [m/s^2] x, y, z then angular rate [rad/s] x, y, z in the **device frame** (z
    down); ``gt`` (N, 3) foot position [m] from VICON interpolated to every sample,
    VICON frame made right-handed ENU (stored y negated, see
    :data:`ENU_FROM_DATASET_XY`; z up); ``zv`` zero-velocity labels (N,) bool per detector name;
    ``thresholds`` each detector's tuned threshold ``G_<det>_opt``;
    ``trial_error`` (5,) the published error per detector (order: probably
    :data:`VICON_DETECTORS`), ``best_detector`` and ``best_error`` as stored.
    """

    path: Path
    ts: np.ndarray
    imu: np.ndarray
    gt: np.ndarray
    zv: dict[str, np.ndarray]
    thresholds: dict[str, float]
    trial_error: np.ndarray
    best_detector: str
    best_error: float


@dataclass(frozen=True)
class IndoorWalk(_ImuColumns):
    """One indoor walk as arrays.

    ``ts`` (N,) [s] from 0; ``imu`` (N, 6) as in :class:`ViconTrial` (device frame,
    z down); ``stride_index`` (K,) **0-based** sample index of each stride (checked on
    walk 31, whose ``traj_wcf[strideIndex]`` equals its ``reconstructed_traj_wcf``);
    ``gcp`` (K, 2) surveyed footprint [m] at each stride, the ground truth;
    ``pyshoe`` (N, 2) PyShoe's stored trajectory [m] (both with the stored y negated,
    see :data:`ENU_FROM_DATASET_XY`); ``theta``, ``theta_pyshoe``,
    ``theta_gcp`` the stored heading offsets [rad]; ``traveled_distance`` [m] and
    ``traverse_time`` [s] as stored.
    """

    path: Path
    ts: np.ndarray
    imu: np.ndarray
    stride_index: np.ndarray
    gcp: np.ndarray
    pyshoe: np.ndarray
    theta: float
    theta_pyshoe: float
    theta_gcp: float
    traveled_distance: float
    traverse_time: float

    @property
    def stride_times(self) -> np.ndarray:
        """(K,) time [s] of each GCP footprint."""
        return self.ts[self.stride_index]


#: Motion classes of the VICON trials (:func:`vicon_motion`).
VICON_MOTIONS = ("walk", "run", "crawl", "irregular")
_REST_ACCEL = 0.5        # [m/s^2] |f| within this of 9.81 ...
_REST_GYRO = 0.5         # [rad/s] ... and |w| below this: a resting foot
_IRREGULAR_SPEED = 0.25  # [m/s] mean horizontal speed below which ...
_IRREGULAR_RISE = 0.4    # [m] ... a height range above this is stepping on and off things
_RUN_PEAK = 40.0         # [m/s^2] median of the 1-s peaks of |f| above which it is running
_MOVING_GYRO = 3.0       # [rad/s] a 1-s window with a faster rotation is moving


def vicon_motion(trial: ViconTrial) -> str:
    """What the wearer does in a VICON trial: walk, run, crawl or irregular.

    The dataset does not label its trials (its README: "some are crawling, running or
    irregular motion"); PyShoe's own scripts name four walking and five running trials
    (``train_motion_classifier.py``), and this rule agrees with all nine:

    * ``crawl``: the resting foot is upside down (the median of the device's down axis
      over resting samples points up: on hands and knees the boot lies on its toe cap);
    * ``irregular``: the foot hardly travels (mean horizontal VICON speed under
      0.25 m/s) but rises more than 0.4 m (stepping onto and off a platform in place);
    * ``run``: the median over moving 1-s windows of the peak specific force exceeds
      40 m/s^2 (4 g impacts; walking stays near 2-3.5 g);
    * ``walk``: everything else.
    """
    an = np.linalg.norm(trial.accel, axis=1)
    gn = np.linalg.norm(trial.gyro, axis=1)
    rest = (np.abs(an - 9.81) < _REST_ACCEL) & (gn < _REST_GYRO)
    if rest.any() and np.median(-trial.accel[rest, 2] / an[rest]) < 0.0:
        return "crawl"
    duration = float(trial.ts[-1] - trial.ts[0])
    horizontal = float(np.sum(np.hypot(*np.diff(trial.gt[::10, :2], axis=0).T)))
    if horizontal < _IRREGULAR_SPEED * duration and np.ptp(trial.gt[:, 2]) > _IRREGULAR_RISE:
        return "irregular"
    n = max(1, int(round(1.0 / float(np.median(np.diff(trial.ts))))))
    k = len(an) // n
    peaks = an[:k * n].reshape(k, n).max(axis=1)
    moving = gn[:k * n].reshape(k, n).max(axis=1) > _MOVING_GYRO
    return "run" if moving.any() and np.median(peaks[moving]) > _RUN_PEAK else "walk"


# -- loading -------------------------------------------------------------------------

def _loadmat(path: Path) -> dict:
    import scipy.io

    try:
        return scipy.io.loadmat(str(path))
    except (ValueError, TypeError, NotImplementedError, OSError) as exc:
        if isinstance(exc, FileNotFoundError):
            raise
        raise ReaderError(f"{path}: not a readable MATLAB file ({exc})") from None


def _matrix(data: dict, key: str, path: Path, cols: int | None = None, rows: int | None = None
            ) -> np.ndarray:
    """A float variable; a row/column vector becomes (n,), else checked as (rows, cols)."""
    if key not in data:
        raise ReaderError(f"{path}: variable '{key}' is missing")
    a = np.asarray(data[key])
    if not np.issubdtype(a.dtype, np.number):
        raise ReaderError(f"{path}: variable '{key}' is not numeric ({a.dtype})")
    a = a.astype(float)
    if cols is None:
        if a.ndim == 2 and 1 in a.shape:
            a = a.ravel()
        if a.ndim != 1 or (rows is not None and len(a) != rows):
            raise ReaderError(f"{path}: '{key}' should be a vector of {rows or 'n'} values, "
                              f"got shape {np.shape(data[key])}")
        return a
    if a.ndim != 2 or a.shape[1] != cols or (rows is not None and a.shape[0] != rows):
        raise ReaderError(f"{path}: '{key}' should be ({rows or 'N'}, {cols}), got {a.shape}")
    return a


def _scalar(data: dict, key: str, default: float = float("nan")) -> float:
    a = np.asarray(data.get(key, default), dtype=float).ravel()
    return float(a[0]) if a.size else default


def _imu_mat(path: str | Path, ts_key: str, imu_key: str
             ) -> tuple[Path, dict, np.ndarray, np.ndarray]:
    """(path, variables, times (n,) [s], IMU (n, 6)) of a recording ``.mat`` whose
    times are ``ts_key`` and whose accelerometer and gyroscope columns are ``imu_key``."""
    path = Path(path)
    data = _loadmat(path)
    ts = _matrix(data, ts_key, path)
    return path, data, ts, _matrix(data, imu_key, path, cols=6, rows=len(ts))


def load_vicon_trial(path: str | Path) -> ViconTrial:
    """Load a PyShoe VICON trial ``.mat`` (see :class:`ViconTrial`)."""
    path, data, ts, imu = _imu_mat(path, "ts", "imu")
    n = len(ts)
    gt = _matrix(data, "gt", path, cols=3, rows=n)
    gt[:, :2] *= ENU_FROM_DATASET_XY
    zv = {d: _matrix(data, f"zv_{d}_opt", path, rows=n).astype(bool)
          for d in VICON_DETECTORS if f"zv_{d}_opt" in data}
    thresholds = {d: _scalar(data, f"G_{d}_opt") for d in VICON_DETECTORS
                  if f"G_{d}_opt" in data}
    best = np.asarray(data.get("best_detector", [""])).ravel()
    return ViconTrial(path=path, ts=ts, imu=imu, gt=gt, zv=zv, thresholds=thresholds,
                      trial_error=np.asarray(data.get("trial_error", []), float).ravel(),
                      best_detector=str(best[0]).strip() if best.size else "",
                      best_error=_scalar(data, "best_error"))


def load_indoor_walk(path: str | Path) -> IndoorWalk:
    """Load an indoor walk ``.mat`` (see :class:`IndoorWalk`)."""
    path, data, ts, imu = _imu_mat(path, "timestamps", "imu_data")
    n = len(ts)
    stride = _matrix(data, "strideIndex", path)
    if np.any(stride != np.round(stride)) or np.any((stride < 0) | (stride >= n)):
        raise ReaderError(f"{path}: strideIndex must hold sample indices 0..{n - 1}")
    gcp = _matrix(data, "GCP", path, cols=2, rows=len(stride)) * ENU_FROM_DATASET_XY
    pyshoe = (_matrix(data, "pyshoeTrajectory", path, cols=2, rows=n) * ENU_FROM_DATASET_XY
              if "pyshoeTrajectory" in data else np.full((n, 2), np.nan))
    return IndoorWalk(path=path, ts=ts, imu=imu, stride_index=stride.astype(np.int64), gcp=gcp,
                      pyshoe=pyshoe, theta=_scalar(data, "theta"),
                      theta_pyshoe=_scalar(data, "thetaPyShoe"),
                      theta_gcp=_scalar(data, "thetaGCP"),
                      traveled_distance=_scalar(data, "traveled_distance"),
                      traverse_time=_scalar(data, "traverse_time"))


# -- readers (messages for the recording source) ---------------------------------------

def _decimation(ts: np.ndarray) -> np.ndarray:
    """Indices of ``ts`` spaced about 1/TRAJECTORY_RATE_HZ apart (first and last kept)."""
    dt = np.median(np.diff(ts)) if len(ts) > 1 else 1.0
    step = max(1, int(round(1.0 / (TRAJECTORY_RATE_HZ * dt)))) if dt > 0 else 1
    idx = np.arange(0, len(ts), step)
    return idx if idx[-1] == len(ts) - 1 else np.append(idx, len(ts) - 1)


class _MatRecording:
    """Messages of several ports merged into one time order, with the known span."""

    def __init__(self, ts: np.ndarray, ports: list[Iterator[tuple[str, Message]]]):
        finite = ts[np.isfinite(ts)]
        self._span = (float(finite.min()), float(finite.max())) if finite.size else None
        self._ports = ports

    def duration(self) -> tuple[float, float] | None:
        return self._span

    def __iter__(self) -> Iterator[tuple[str, Message]]:
        return heapq.merge(*self._ports, key=lambda pm: pm[1].t)


def _imu_port(ts: np.ndarray, imu: np.ndarray, options: ReadOptions
              ) -> Iterator[tuple[str, Message]]:
    for block in imu_blocks(ts, imu[:, :3], imu[:, 3:], block_s=options.block_s,
                            agent=options.agent, device=options.device):
        yield "imu", block


def read_vicon_trial(path: Path, options: ReadOptions) -> _MatRecording:
    """Reader for a PyShoe VICON trial: ports ``imu`` and ``truth`` (VICON frame, 20 Hz)."""
    trial = load_vicon_trial(path)

    def truth() -> Iterator[tuple[str, Message]]:
        for i in _decimation(trial.ts):
            yield "truth", GroundTruth(t=float(trial.ts[i]), agent=options.agent,
                                       device="vicon", position=trial.gt[i].copy(),
                                       frame="vicon")

    return _MatRecording(trial.ts, [_imu_port(trial.ts, trial.imu, options), truth()])


def read_indoor_walk(path: Path, options: ReadOptions) -> _MatRecording:
    """Reader for an indoor walk: ports ``imu``, ``truth`` (GCP per stride), ``reference``."""
    walk = load_indoor_walk(path)

    def truth() -> Iterator[tuple[str, Message]]:
        for t, (x, y) in zip(walk.stride_times, walk.gcp):
            yield "truth", GroundTruth(t=float(t), agent=options.agent, device="gcp",
                                       position=np.array([x, y, 0.0]), frame="survey")

    def reference() -> Iterator[tuple[str, Message]]:
        cov = np.full((4, 4), np.nan)
        for i in _decimation(walk.ts):
            x, y = walk.pyshoe[i]
            if np.isfinite(x) and np.isfinite(y):
                yield "reference", PoseEstimate(t=float(walk.ts[i]), agent=options.agent,
                                                device="pyshoe", position=np.array([x, y, 0.0]),
                                                heading=float("nan"), cov=cov)

    return _MatRecording(walk.ts, [_imu_port(walk.ts, walk.imu, options), truth(), reference()])


#: PyShoe's hallway and stair trials sample their IMU at 200 Hz (``ins_demos.py``: T=1/200).
PYSHOE_RATE_HZ = 200.0
_PYSHOE_SPARSE_KEYS = ("imu", "gt", "gt_idx")


def read_pyshoe_sparse(path: Path, options: ReadOptions) -> _MatRecording:
    """Reader for PyShoe's hallway and stair trials (``processed_data.mat``): ``imu``
    (N, 6) as the VICON trials, ``ts`` (or 200 Hz), truth ``gt`` at the samples
    ``gt_idx``: (M, 3) total-station points of a hallway trial, published on ``truth``
    (stored y negated as for the VICON trials, frame ``pyshoe``), or the heights (M,) of a
    stair trial, which are not a position: those are counted, not published."""
    path = Path(path)
    data = _loadmat(path)
    imu = _matrix(data, "imu", path, cols=6)
    n = len(imu)
    ts = (_matrix(data, "ts", path, rows=n) if "ts" in data
          else np.arange(n) / PYSHOE_RATE_HZ)
    idx = _matrix(data, "gt_idx", path)
    if np.any(idx != np.round(idx)) or np.any((idx < 0) | (idx >= n)):
        raise ReaderError(f"{path}: gt_idx must hold sample indices 0..{n - 1}")
    idx = idx.astype(np.int64)
    gt = np.asarray(data["gt"], float)
    ports = [_imu_port(ts, imu, options)]
    if gt.ndim == 2 and gt.shape == (len(idx), 3):
        gt = gt.copy()
        gt[:, :2] *= ENU_FROM_DATASET_XY

        def truth() -> Iterator[tuple[str, Message]]:
            for i, p in zip(idx, gt):
                yield "truth", GroundTruth(t=float(ts[i]), agent=options.agent,
                                           device="pyshoe_gt", position=p.copy(),
                                           frame="pyshoe")

        ports.append(truth())
    else:
        options.count("height_only_truth", len(idx))
    return _MatRecording(ts, ports)


def read_mat(path: Path, options: ReadOptions) -> _MatRecording:
    """Pick the dataset reader from the variables the ``.mat`` file holds."""
    import scipy.io

    try:
        names = {name for name, _, _ in scipy.io.whosmat(str(path))}
    except (ValueError, TypeError, NotImplementedError) as exc:
        raise ReaderError(f"{path}: not a readable MATLAB file ({exc})") from None
    if all(k in names for k in _PYSHOE_SPARSE_KEYS):
        return read_pyshoe_sparse(path, options)
    if all(k in names for k in _VICON_KEYS):
        return read_vicon_trial(path, options)
    if all(k in names for k in _WALK_KEYS):
        return read_indoor_walk(path, options)
    raise ReaderError(
        f"{path}: unknown .mat content (variables: {', '.join(sorted(names)) or 'none'}); "
        f"expected a PyShoe VICON trial ({', '.join(_VICON_KEYS)}), a PyShoe hallway or "
        f"stair trial ({', '.join(_PYSHOE_SPARSE_KEYS)}) or an indoor walk "
        f"({', '.join(_WALK_KEYS)})")


READERS = {".mat": read_mat}
FORMATS = {"pyshoe_vicon": read_vicon_trial, "indoor_walk": read_indoor_walk,
           "pyshoe": read_pyshoe_sparse}
