"""Track error against ground truth: the numbers every benchmark and `evaluate` reports.

Dense truth (the simulator's, tens of Hz): errors are computed at the estimate's own
times, against the truth interpolated linearly to those times; only estimates inside
the truth's time span count. Sparse truth (surveyed checkpoints, one per stride or
per stop) is handled by :mod:`.checkpoints`, which interpolates the *estimate* to the
checkpoint times instead.

Definitions (all distances horizontal unless said otherwise, metres, seconds):

* ``rmse_m``, ``mean_m``, ``median_m``, ``p90_m``, ``p95_m``, ``max_m``: of the
  horizontal error samples;
* ``distance_m``: length of the TRUE path over the evaluated span;
* ``mean_pct_distance`` / ``max_pct_distance``: mean / max error as a percentage of
  that distance (the breadcrumb paper's "error factor", Sec. V-A: 5.6 m average and
  10.9 m maximum over 400 m = 1.4 % and 2.7 %);
* ``vertical_rmse_m``: RMS of estimate z - true z (None if the estimate has no z);
* ``floor_accuracy``: fraction of estimates whose floor index equals the true floor
  (None if the estimator reports no floors). While the true height is on a stair flight
  or landing, more than :data:`STAIR_BAND_M` from every floor level, the firefighter is
  between two floors and either of them counts as right (needs the floor levels);
* ``converge_s``: time from the first estimate until the error drops below
  ``bound_m`` for good (None if it never stays below). It reads the truth: a figure
  for the evaluator, not a rule a filter could apply.

Convergence as the search-pattern paper defines it (Sec. V-E, Fig. 9 a: "the search has
been divided into four periods based on whether the estimated variance exceeds or falls
below 3 m^2", the first period being "before the filter has converged"; Sec. V-C, VI:
the "steady-state RMSE" once the filter "stabilizes"). The rule reads only the
estimate's own published covariance, never the truth:

* ``variance_converge_s``: seconds from the first estimate to the first estimate from
  which the estimate's own horizontal variance ``cov[0,0] + cov[1,1]`` stays at or
  below :data:`CONVERGED_VARIANCE_M2` for at least :data:`CONVERGED_HOLD_S` (the hold
  keeps a single collapsed resampling from counting); None if that never happens. An
  estimator that starts from a known, tight pose converges at 0;
* ``rmse_after_convergence_m``: the paper's metric, the RMSE of the horizontal errors
  from that moment to the end of the track (later divergences, e.g. at a map error,
  count: the paper's steady state includes its periods 3 and 4); None if the track
  never converges;
* ``converged_fraction``: 1 if the track converges, 0 if not; pooled, the share of
  tracks that converge (of runs, for one firefighter per run). None without a
  covariance.

Integrity (whether the estimate's own uncertainty holds its promises; dense truth only):

* ``ellipse95_containment``: fraction of estimates whose true position lies inside
  their 95 % horizontal covariance ellipse (squared Mahalanobis distance <= 5.991);
  about 0.95 for a consistent covariance;
* ``nees_xy``: mean horizontal normalised estimation error squared (2 for a
  consistent covariance, larger when it is optimistic);
* ``protection_containment``: fraction of estimates with a finite protection radius
  whose error is within it (the radius promises 0.99);
* ``trusted_fraction``: fraction of estimates flagged trusted;
* ``trusted_off_fraction``: fraction of ALL estimates that are trusted while more than
  :data:`ALERT_LIMIT_M` off: the failure a commander cannot see.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np

from ..tracks import Track

#: A true height farther than this [m] from every floor level is "between floors".
STAIR_BAND_M = 0.5
#: Error [m] beyond which a trusted pose counts as confidently wrong.
ALERT_LIMIT_M = 3.0
#: chi-square (2 degrees of freedom) 95 % quantile: the 95 % ellipse's squared radius.
CHI2_2_95 = 5.991464547107979
#: The search-pattern paper's convergence threshold on var_x + var_y [m^2] (Sec. V-E).
CONVERGED_VARIANCE_M2 = 3.0
#: How long [s] the variance must stay below the threshold for the track to have converged.
CONVERGED_HOLD_S = 10.0


def floor_right(floor_est: np.ndarray, floor_true: np.ndarray, z_true: np.ndarray,
                floor_levels: np.ndarray | None) -> np.ndarray:
    """1.0 where the estimated floor is right, 0.0 where wrong, NaN where either is unknown.

    Between floors (see :data:`STAIR_BAND_M`) the floors just below and above the true
    height both count as right; without ``floor_levels`` only the true floor does.
    """
    known = (floor_est >= 0) & (floor_true >= 0)
    ok = floor_est == floor_true
    if floor_levels is not None and len(floor_levels) > 1:
        levels = np.sort(np.asarray(floor_levels, float))
        between = np.min(np.abs(z_true[:, None] - levels[None, :]), axis=1) > STAIR_BAND_M
        below = np.clip(np.searchsorted(levels, z_true, side="right") - 1, 0, len(levels) - 1)
        ok |= between & ((floor_est == below) | (floor_est == below + 1))
    return np.where(known, ok.astype(float), np.nan)

#: Default error bound for the convergence time [m] (search-pattern paper, Sec. V-C:
#: the filter "stabilizes at a RMSE of about one meter"; twice that counts as settled).
CONVERGE_BOUND_M = 2.0


def horizontal_errors(track: Track, truth: Track) -> tuple[np.ndarray, np.ndarray]:
    """(times, horizontal error [m]) of ``track`` against ``truth``."""
    if len(track) == 0 or len(truth) < 2:
        return np.empty(0), np.empty(0)
    inside = (track.t >= truth.t[0]) & (track.t <= truth.t[-1])
    t = track.t[inside]
    tx = np.interp(t, truth.t, truth.position[:, 0])
    ty = np.interp(t, truth.t, truth.position[:, 1])
    return t, np.hypot(track.position[inside, 0] - tx, track.position[inside, 1] - ty)


@dataclass(frozen=True)
class ErrorStats:
    """Summary statistics of a horizontal error series [m]."""

    n: int
    rmse_m: float
    mean_m: float
    median_m: float
    p90_m: float
    p95_m: float
    max_m: float

    def as_dict(self) -> dict:
        return asdict(self)


def error_stats(errors: np.ndarray) -> ErrorStats:
    e = np.asarray(errors, float)
    e = e[np.isfinite(e)]
    if e.size == 0:
        nan = math.nan
        return ErrorStats(0, nan, nan, nan, nan, nan, nan)
    return ErrorStats(n=int(e.size), rmse_m=float(np.sqrt(np.mean(e ** 2))),
                      mean_m=float(e.mean()), median_m=float(np.median(e)),
                      p90_m=float(np.percentile(e, 90)), p95_m=float(np.percentile(e, 95)),
                      max_m=float(e.max()))


def path_length(xy: np.ndarray) -> float:
    """Length of a polyline (N, 2) [m]."""
    return float(np.sum(np.hypot(*np.diff(xy, axis=0).T))) if len(xy) > 1 else 0.0


def convergence_time(t: np.ndarray, errors: np.ndarray, bound_m: float) -> float | None:
    """Seconds from ``t[0]`` until ``errors`` stay at or below ``bound_m`` to the end."""
    if len(t) == 0:
        return None
    above = np.flatnonzero(~(errors <= bound_m))
    if len(above) == 0:
        return 0.0
    last = above[-1]
    if last == len(t) - 1:
        return None
    return float(t[last + 1] - t[0])


def variance_convergence_time(t: np.ndarray, var_xy: np.ndarray,
                              limit_m2: float = CONVERGED_VARIANCE_M2,
                              hold_s: float = CONVERGED_HOLD_S) -> float | None:
    """Seconds from ``t[0]`` to the first time from which ``var_xy`` [m^2] stays at or
    below ``limit_m2`` for at least ``hold_s`` seconds (None: never; NaN counts as above)."""
    if len(t) == 0 or len(var_xy) != len(t):
        return None
    below = np.asarray(var_xy, float) <= limit_m2
    if not below.any():
        return None
    edges = np.diff(np.concatenate([[0], below.astype(np.int8), [0]]))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
    ok = np.flatnonzero(t[ends] - t[starts] >= hold_s)
    return float(t[starts[ok[0]]] - t[0]) if ok.size else None


def after_convergence(err: "TrackErrors") -> np.ndarray | None:
    """The horizontal errors [m] from the track's variance convergence on (None: never)."""
    tc = variance_convergence_time(err.t, err.var_xy)
    if tc is None:
        return None
    return err.horizontal[err.t >= err.t[0] + tc]


@dataclass
class TrackErrors:
    """Error series of one estimated track against its truth (for metrics and plots)."""

    agent: str
    t: np.ndarray             # (N,) estimate times inside the truth span
    horizontal: np.ndarray    # (N,) [m]
    vertical: np.ndarray      # (N,) estimate z - true z [m] (NaN: unknown)
    floor_ok: np.ndarray      # (N,) 1.0 right floor, 0.0 wrong, NaN unknown
    distance_m: float         # true path length over the span
    mahalanobis2: np.ndarray = field(default_factory=lambda: np.empty(0))  # (N,) NaN: no cov
    protection: np.ndarray = field(default_factory=lambda: np.empty(0))    # (N,) [m], inf: none
    trusted: np.ndarray = field(default_factory=lambda: np.empty(0, bool))  # (N,)
    var_xy: np.ndarray = field(default_factory=lambda: np.empty(0))  # (N,) cov xx + yy [m^2]


def track_errors(track: Track, truth: Track, floor_levels: np.ndarray | None = None
                 ) -> TrackErrors:
    """Errors of ``track`` against dense ``truth`` at the estimate's times.

    ``floor_levels`` (the building's floor heights [m]) lets the floor check accept
    either neighbouring floor while the truth is on the stairs between them.
    """
    t, e = horizontal_errors(track, truth)
    n = len(t)
    if n == 0:
        return TrackErrors(track.agent, t, e, np.empty(0), np.empty(0), 0.0)
    inside = (track.t >= truth.t[0]) & (track.t <= truth.t[-1])
    z_true = np.interp(t, truth.t, truth.position[:, 2])
    vertical = track.position[inside, 2] - z_true
    floor_est = track.floor[inside]
    idx = np.clip(np.searchsorted(truth.t, t, side="right") - 1, 0, len(truth) - 1)
    # nearest truth sample's floor (floors are integers: no interpolation)
    nxt = np.clip(idx + 1, 0, len(truth) - 1)
    near = np.where(np.abs(truth.t[nxt] - t) < np.abs(truth.t[idx] - t), nxt, idx)
    floor_ok = floor_right(floor_est, truth.floor[near], z_true, floor_levels)
    span = (truth.t >= t[0]) & (truth.t <= t[-1])
    dist = path_length(truth.position[span, :2])
    dxy = track.position[inside, :2] - np.column_stack(
        [np.interp(t, truth.t, truth.position[:, 0]), np.interp(t, truth.t, truth.position[:, 1])])
    return TrackErrors(track.agent, t, e, vertical, floor_ok, dist,
                       mahalanobis2=horizontal_mahalanobis2(dxy, track.cov[inside]),
                       protection=track.protection_radius[inside],
                       trusted=track.trusted[inside],
                       var_xy=track.cov[inside, 0, 0] + track.cov[inside, 1, 1])


def horizontal_mahalanobis2(dxy: np.ndarray, cov: np.ndarray) -> np.ndarray:
    """Squared Mahalanobis distances of errors ``dxy`` (N, 2) [m] under the horizontal
    blocks of ``cov`` (N, 4, 4); NaN where a covariance is not positive definite."""
    c = cov[:, :2, :2]
    a, b, d = c[:, 0, 0], 0.5 * (c[:, 0, 1] + c[:, 1, 0]), c[:, 1, 1]
    det = a * d - b * b
    with np.errstate(divide="ignore", invalid="ignore"):
        m2 = (d * dxy[:, 0] ** 2 - 2 * b * dxy[:, 0] * dxy[:, 1] + a * dxy[:, 1] ** 2) / det
    return np.where((det > 0) & (a > 0) & np.isfinite(m2), m2, np.nan)


def _finite_or_none(v: float) -> float | None:
    return None if v is None or not math.isfinite(v) else float(v)


@dataclass
class TrackMetrics:
    """The reported figures of one track (or a pool of tracks); None: does not apply."""

    n: int
    rmse_m: float | None
    mean_m: float | None
    median_m: float | None
    p90_m: float | None
    p95_m: float | None
    max_m: float | None
    mean_pct_distance: float | None
    max_pct_distance: float | None
    distance_m: float | None
    vertical_rmse_m: float | None
    floor_accuracy: float | None
    converge_s: float | None
    ellipse95_containment: float | None = None
    nees_xy: float | None = None
    protection_containment: float | None = None
    trusted_fraction: float | None = None
    trusted_off_fraction: float | None = None
    variance_converge_s: float | None = None
    rmse_after_convergence_m: float | None = None
    converged_fraction: float | None = None

    def as_dict(self) -> dict:
        return asdict(self)


INTEGRITY_KEYS = ("ellipse95_containment", "nees_xy", "protection_containment",
                  "trusted_fraction", "trusted_off_fraction")
CONVERGENCE_KEYS = ("variance_converge_s", "rmse_after_convergence_m", "converged_fraction")
KEYS = ("rmse_m", "mean_m", "median_m", "p90_m", "p95_m", "max_m", "mean_pct_distance",
        "max_pct_distance", "distance_m", "vertical_rmse_m", "floor_accuracy", "converge_s",
        *INTEGRITY_KEYS, *CONVERGENCE_KEYS)
#: Times to converge: a run that never converges counts as infinitely late in a spread.
TIME_KEYS = ("converge_s", "variance_converge_s")


def convergence_figures(err: TrackErrors) -> dict[str, float | None]:
    """The paper's convergence figures of the module docstring for one track."""
    if len(err.t) == 0 or len(err.var_xy) != len(err.t):
        return dict.fromkeys(CONVERGENCE_KEYS)
    after = after_convergence(err)
    return {"variance_converge_s": variance_convergence_time(err.t, err.var_xy),
            "rmse_after_convergence_m": (_finite_or_none(float(np.sqrt(np.mean(after ** 2))))
                                         if after is not None and after.size else None),
            "converged_fraction": 0.0 if after is None else 1.0}


def integrity_figures(err: TrackErrors) -> dict[str, float | None]:
    """The integrity figures of the module docstring (None where they do not apply)."""
    n = len(err.horizontal)
    if n == 0 or len(err.trusted) != n:
        return dict.fromkeys(INTEGRITY_KEYS)
    m2 = err.mahalanobis2[np.isfinite(err.mahalanobis2)]
    finite_pr = np.isfinite(err.protection)
    return {
        "ellipse95_containment": float(np.mean(m2 <= CHI2_2_95)) if m2.size else None,
        "nees_xy": float(np.mean(m2)) if m2.size else None,
        "protection_containment": (float(np.mean(err.horizontal[finite_pr]
                                                 <= err.protection[finite_pr]))
                                   if finite_pr.any() else None),
        "trusted_fraction": float(np.mean(err.trusted)),
        "trusted_off_fraction": float(np.mean(err.trusted & (err.horizontal > ALERT_LIMIT_M))),
    }


def metrics_of(err: TrackErrors, bound_m: float = CONVERGE_BOUND_M) -> TrackMetrics:
    """All reported figures of one track's errors."""
    s = error_stats(err.horizontal)
    d = err.distance_m if err.distance_m > 0 else math.nan
    vert = err.vertical[np.isfinite(err.vertical)]
    fl = err.floor_ok[np.isfinite(err.floor_ok)]
    return TrackMetrics(
        n=s.n, rmse_m=_finite_or_none(s.rmse_m), mean_m=_finite_or_none(s.mean_m),
        median_m=_finite_or_none(s.median_m), p90_m=_finite_or_none(s.p90_m),
        p95_m=_finite_or_none(s.p95_m), max_m=_finite_or_none(s.max_m),
        mean_pct_distance=_finite_or_none(100.0 * s.mean_m / d),
        max_pct_distance=_finite_or_none(100.0 * s.max_m / d),
        distance_m=_finite_or_none(d),
        vertical_rmse_m=_finite_or_none(float(np.sqrt(np.mean(vert ** 2)))) if vert.size else None,
        floor_accuracy=float(fl.mean()) if fl.size else None,
        converge_s=convergence_time(err.t, err.horizontal, bound_m),
        **integrity_figures(err), **convergence_figures(err))


def pooled_metrics(errs: list[TrackErrors], bound_m: float = CONVERGE_BOUND_M) -> TrackMetrics:
    """Figures over several tracks (agents x runs).

    Error statistics pool every sample; ``distance_m`` is the mean true distance per
    track; the percentages are means over tracks of each track's own percentage (as the
    breadcrumb paper averages its eight traces); ``converge_s`` is the median over
    tracks, a track that never converges counting as infinitely late (None when at
    least half never converge); the same for ``variance_converge_s``;
    ``rmse_after_convergence_m`` pools every converged track's errors after its own
    convergence; ``converged_fraction`` is the share of tracks that converge.
    """
    if not errs:
        return TrackMetrics(0, *([None] * len(KEYS)))
    per = [metrics_of(e, bound_m) for e in errs]
    pooled = metrics_of(TrackErrors("", np.concatenate([e.t for e in errs]),
                                    np.concatenate([e.horizontal for e in errs]),
                                    np.concatenate([e.vertical for e in errs]),
                                    np.concatenate([e.floor_ok for e in errs]), 0.0,
                                    np.concatenate([e.mahalanobis2 for e in errs]),
                                    np.concatenate([e.protection for e in errs]),
                                    np.concatenate([e.trusted for e in errs])), bound_m)

    def mean_of(key: str) -> float | None:
        vals = [getattr(m, key) for m in per if getattr(m, key) is not None]
        return float(np.mean(vals)) if vals else None

    conv = np.array([math.inf if m.converge_s is None else m.converge_s for m in per])
    med = float(np.median(conv)) if len(conv) else math.inf
    pooled.mean_pct_distance = mean_of("mean_pct_distance")
    pooled.max_pct_distance = mean_of("max_pct_distance")
    pooled.distance_m = mean_of("distance_m")
    pooled.converge_s = med if math.isfinite(med) else None
    _pool_convergence(pooled, errs, per)
    return pooled


def _pool_convergence(pooled: TrackMetrics, errs: list[TrackErrors],
                      per: list[TrackMetrics]) -> None:
    """Set the pooled convergence figures of :func:`pooled_metrics` from the tracks'."""
    with_cov = [(e, m) for e, m in zip(errs, per) if m.converged_fraction is not None]
    if not with_cov:
        return
    times = np.array([math.inf if m.variance_converge_s is None else m.variance_converge_s
                      for _, m in with_cov])
    med = float(np.median(times))
    after = [a for a in (after_convergence(e) for e, _ in with_cov) if a is not None]
    after_all = np.concatenate(after) if after else np.empty(0)
    pooled.variance_converge_s = med if math.isfinite(med) else None
    pooled.rmse_after_convergence_m = (_finite_or_none(float(np.sqrt(np.mean(after_all ** 2))))
                                       if after_all.size else None)
    pooled.converged_fraction = float(np.mean([m.converged_fraction for _, m in with_cov]))
