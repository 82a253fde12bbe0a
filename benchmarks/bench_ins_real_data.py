"""Accuracy of the ZUPT-aided INS on the two real foot-IMU datasets, beside their references.

    .venv/bin/python benchmarks/bench_ins_real_data.py            # tables + summary
    .venv/bin/python benchmarks/bench_ins_real_data.py --tune     # redo the detector tuning
    .venv/bin/python benchmarks/bench_ins_real_data.py --heading  # odometry heading sigma
    .venv/bin/python benchmarks/bench_ins_real_data.py --xio DIR --zupt-fgo DIR/measData
                                   # and the public recordings, where you have them
    .venv/bin/python benchmarks/bench_ins_real_data.py --integrity  # the poses' covariance

PyShoe VICON set (56 trials): the 2D ARMSE exactly as PyShoe defines it (rotation
alignment at the first sample 0.8 m from the start; per-sample RMS over x and y, see
``zupt_ins.metrics``). References: the per-trial-optimal errors stored in each file
(a threshold tuned per trial on the ground truth: an upper bound on what a fixed
detector can do) and fixed-threshold SHOE through our filter with PyShoe's settings
(which reproduces PyShoe: tests/ins/test_real_data.py).

Indoor walks (8): horizontal error at the surveyed strides after a rigid 2D fit on
the first 5 strides only, in metres and % of the surveyed distance; reference: the
``pyshoeTrajectory`` stored in each file (PyShoe with its LSTM detector), scored the same way.

One configuration for everything: the plugin defaults. ``--tune`` repeats how the
adaptive detector's defaults and the fixed detectors' default thresholds were chosen:
on the even-numbered VICON trials only (sorted by name), then reports the held-out odd
trials and the walks, which played no part in the choice.

``--heading`` checks the heading uncertainty the odometry publishes against the heading
drift of the indoor walks: the increments' heading variances summed as a consumer sums
them plus the published drift-rate sigma (``Odometry.yaw_drift_rate_sigma``, from
``odometry.yaw_drift_rate_sigma``, 0.17 deg/s) times the time ("now"; a consumer with a
drift state), beside the increments alone ("before"), and the drift
(``simulator.recordings.heading_drift``, slope of the step headings' error) times the
walk's duration.

Options of the zupt-extension paper are measured on/off: retrospective correction
(full-rate track: VICON ARMSE) and level-floor height correction (vertical error:
VICON mean |dz| against the VICON height, walks mean |z| at the strides, the floors
being level).
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from firenav_framework.evaluation.metrics import (  # noqa: E402
    TrackErrors, horizontal_mahalanobis2, integrity_figures)
from firenav_framework.integrity import gaussian_protection_radius, trusted  # noqa: E402
from firenav_framework.sources.readers.foot_imu_datasets import (  # noqa: E402
    VICON_MOTIONS, IndoorWalk, ViconTrial, load_indoor_walk, load_vicon_trial, vicon_motion)
from firenav_plugins.estimators.zupt_ins import BlockResult, InsEngine, ZuptInsParams  # noqa: E402
from firenav_plugins.estimators.zupt_ins import eskf  # noqa: E402
from firenav_plugins.estimators.zupt_ins.metrics import (  # noqa: E402
    path_length, pyshoe_armse, rigid_fit_2d, shape_error_per_distance, stride_errors)
from firenav_plugins.estimators.zupt_ins.retro import correct_positions  # noqa: E402
from firenav_plugins.estimators.zupt_ins.steps import StepTracker  # noqa: E402
from firenav_plugins.estimators.zupt_ins.clipping import ClipLog  # noqa: E402

FLU = np.array([1.0, -1.0, -1.0])     # the datasets' z-down MicroStrain -> FLU
RATE = 200.0
N_ALIGN = 5                           # strides used to fit the walks' unknown start pose
#: Indoor walks (file order) of the tuning half: 32, 34, 36, 38; 31, 33, 35, 37 are held out.
WALK_TUNING = slice(1, None, 2)
PYSHOE_SETTINGS = {"gravity": {"magnitude": 9.8029}}  # PyShoe's g; its filter noise = ours


def data_dir() -> Path:
    import os
    env = os.environ.get("FIRENAV_SHARED_DATA")
    return Path(env) if env else REPO.parent / "shared" / "data"


#: The crawl levels of main before they were chosen again on the tuning half (the
#: "main" column).
MAIN = ZuptInsParams(detector={"crawl": {"kappa": 0.35, "min_stance": 0.025,
                                         "smoothing": 0.15}})
#: The previous round's defaults (crawl levels without the averaged statistic, the
#: upright ceiling 10^8.7): the "previous" column.
PREVIOUS = ZuptInsParams(detector={"high": 8.7, "crawl": {"high": 6.6, "kappa": 0.2,
                                                          "min_stance": 0.025,
                                                          "smoothing": 0.0}})
#: The plugin's defaults before crawling got its own detector levels (the upright
#: levels throughout), the level-floor height was held and steps settled into their
#: stance (the "before" column): the same run shows what the changes did.
BEFORE = ZuptInsParams(detector={"high": 8.7,
                                 "crawl": {"low": 6.6, "high": 8.7, "kappa": 0.25,
                                           "prominence": 2.0, "min_stance": 0.04,
                                           "smoothing": 0.0}},
                       height={"correction": False}, outputs={"step_settle": 0.0})


@dataclass
class TrialResult:
    armse: float          # 2D ARMSE [m], full-rate track (retro-corrected if enabled)
    vertical: float       # mean |dz| [m] against the VICON height
    shape: float          # whole-track rigid-fit mean error per metre of VICON path [-]
    path: float           # VICON path length [m]


@dataclass
class WalkResult:
    mean: float           # mean horizontal error at the strides [m]
    final: float          # at the last stride [m]
    percent: float        # mean / distance [%]
    height: float         # mean |z| at the strides [m] (level floors)
    height_max: float     # max |z| at the strides [m]
    height_end: float     # |z| at the last stride [m]
    distance: float       # surveyed distance [m]


def run(params: ZuptInsParams, t: np.ndarray, imu: np.ndarray) -> tuple[BlockResult, np.ndarray]:
    """The INS over one recording; (result, full-rate positions as the plugin outputs them)."""
    eng = InsEngine(params.detector_config(RATE), params.filter_config(RATE))
    res = BlockResult.concat([eng.process(t, imu[:, :3] * FLU, imu[:, 3:] * FLU), eng.finish()])
    pos = res.states[:, eskf.O_POS:eskf.O_POS + 3]
    if params.outputs.retrospective_correction:
        pos = correct_positions(res.states[:, eskf.O_T], pos, res.events)
    return res, pos


def eval_trial(params: ZuptInsParams, tr: ViconTrial) -> TrialResult:
    _, pos = run(params, tr.ts, tr.imu)
    armse = pyshoe_armse(pos[:, :2], tr.gt)
    vertical = float(np.mean(np.abs((pos[:, 2] - pos[0, 2]) - (tr.gt[:, 2] - tr.gt[0, 2]))))
    return TrialResult(armse, vertical, shape_error_per_distance(pos, tr.gt),
                       path_length(tr.gt[::10]))


def eval_walk(params: ZuptInsParams, w: IndoorWalk) -> WalkResult:
    _, pos = run(params, w.ts, w.imu)
    at = pos[w.stride_index]
    e = stride_errors(at[:, :2], w.gcp, n_align=N_ALIGN)
    z = np.abs(at[:, 2] - at[0, 2])
    return WalkResult(e.mean, e.final, e.mean_percent, float(z.mean()), float(z.max()),
                      float(z[-1]), e.distance)


def pyshoe_walk(w: IndoorWalk) -> WalkResult:
    e = stride_errors(w.pyshoe[w.stride_index], w.gcp, n_align=N_ALIGN)
    return WalkResult(e.mean, e.final, e.mean_percent, float("nan"), float("nan"), float("nan"),
                      e.distance)


def vicon_armse(params: ZuptInsParams, trials: list[ViconTrial]) -> np.ndarray:
    return np.array([eval_trial(params, tr).armse for tr in trials])


# -- tuning -----------------------------------------------------------------------------
#: Values tried for the adaptive detector's parameters (``detector`` group).
ADAPTIVE_GRID = {
    "low": [6.0, 6.3, 6.6, 6.9],
    "kappa": [0.15, 0.2, 0.25, 0.3, 0.35],
    "prominence": [1.5, 2.0, 2.5],
    "high": [8.4, 8.7, 9.0, 9.3],
    "floor_back": [0.5, 0.7, 1.0, 1.5],
    "min_stance": [0.005, 0.025, 0.04, 0.06],
}


def with_detector(**detector) -> ZuptInsParams:
    """The plugin defaults with these detector parameters."""
    return ZuptInsParams(detector=detector)
FIXED_GRID = [10 ** e for e in np.arange(5.5, 9.01, 0.25)]


def descend(tune_set: list[ViconTrial], start: dict) -> tuple[dict, float]:
    """Coordinate descent over ADAPTIVE_GRID (two passes) minimising the mean ARMSE."""
    current = dict(start)
    best = vicon_armse(with_detector(**current), tune_set).mean()
    for _ in range(2):
        for key, values in ADAPTIVE_GRID.items():
            for value in values:
                trial = {**current, key: value}
                if trial == current:
                    continue
                try:
                    score = vicon_armse(with_detector(**trial), tune_set).mean()
                except ValueError:
                    continue
                if score < best - 1e-5:
                    best, current = score, trial
    return current, best


def tune(trials: list[ViconTrial], walks: list[IndoorWalk]) -> None:
    """Two-fold cross-validation: tune on one half of the VICON trials, score the other."""
    halves = {"even": trials[0::2], "odd": trials[1::2]}
    defaults = {k: getattr(ZuptInsParams().detector, k) for k in ADAPTIVE_GRID}
    print("Fixed thresholds, best on the even half (the defaults of the fixed detectors):")
    for det in ("shoe", "ared", "amvd"):
        scores = [(vicon_armse(with_detector(kind=det, threshold=g), halves["even"]).mean(), g)
                  for g in FIXED_GRID]
        best, g = min(scores)
        held = vicon_armse(with_detector(kind=det, threshold=g), halves["odd"])
        print(f"  {det:5s} 10^{math.log10(g):.2f}: even mean {best:.3f} m, odd (held out) "
              f"mean {held.mean():.3f} m")
    print(f"\nAdaptive detector, coordinate descent from the defaults {defaults}:")
    for fit, test in (("even", "odd"), ("odd", "even")):
        chosen, score = descend(halves[fit], defaults)
        params = with_detector(**chosen)
        held = vicon_armse(params, halves[test])
        walk_pct = np.mean([eval_walk(params, w).percent for w in walks])
        changed = {k: v for k, v in chosen.items() if v != defaults[k]}
        print(f"  tuned on {fit:4s}: changed {changed or 'nothing'}; {fit} mean {score:.4f} m, "
              f"held-out {test} mean {held.mean():.4f} m, walks {walk_pct:.2f} %")
    base = ZuptInsParams()
    print(f"  defaults: even mean {vicon_armse(base, halves['even']).mean():.4f} m, odd mean "
          f"{vicon_armse(base, halves['odd']).mean():.4f} m, walks "
          f"{np.mean([eval_walk(base, w).percent for w in walks]):.2f} %")


# -- report -----------------------------------------------------------------------------
def split(i: int) -> str:
    """Tuning (even index in name order) or held-out (odd) half of the VICON trials."""
    return "tune" if i % 2 == 0 else "held"


def motion_summary(trials: list[ViconTrial], rows: list[dict[str, TrialResult]],
                   motions: list[str], key: str) -> None:
    """Per motion class and half: mean ARMSE, ARMSE per metre and shape error per metre;
    each class's shape error per metre beside walking's (the crawl target: <= 3x)."""
    print(f"\nBy motion ({key}): mean over trials; 'per m' = ARMSE / VICON path, 'shape/m' ="
          " whole-track rigid-fit mean error / path")
    walk = {}
    for half in ("tune", "held", "all"):
        for motion in VICON_MOTIONS:
            idx = [i for i, m in enumerate(motions) if m == motion
                   and (half == "all" or split(i) == half)]
            if not idx:
                continue
            r = [rows[i][key] for i in idx]
            shape = float(np.mean([x.shape for x in r]))
            if motion == "walk":
                walk[half] = shape
            ratio = f"{shape / walk[half]:4.1f}x walking" if half in walk else ""
            print(f"  {half:4s} {motion:9s} n={len(idx):2d}  ARMSE {np.mean([x.armse for x in r]):6.3f} m"
                  f"  per m {100 * np.mean([x.armse / x.path for x in r]):5.2f} %"
                  f"  shape/m {100 * shape:5.2f} %  {ratio}")


def report(trials: list[ViconTrial], walks: list[IndoorWalk]) -> None:
    ours = ZuptInsParams()
    variants = {
        "ours": ours,
        "main": MAIN,
        "previous": PREVIOUS,
        "before": BEFORE,
        "no retro": ZuptInsParams(outputs={"retrospective_correction": False}),
        "no height": ZuptInsParams(height={"correction": False}),
    }
    fixed = {g: ZuptInsParams(detector={"kind": "shoe", "threshold": g},
                              outputs={"retrospective_correction": False}, **PYSHOE_SETTINGS)
             for g in (1e7, 3e7, 1e8, 5e8)}
    t0 = time.perf_counter()
    motions = [vicon_motion(tr) for tr in trials]
    rows = []
    for i, tr in enumerate(trials):
        r = {k: eval_trial(p, tr) for k, p in variants.items()}
        r.update({f"shoe {g:.0e}": eval_trial(p, tr) for g, p in fixed.items()})
        rows.append(r)
    stored_shoe = np.array([tr.trial_error[0] for tr in trials])
    stored_best = np.array([tr.best_error for tr in trials])

    print("PyShoe VICON trials: 2D ARMSE [m] (PyShoe's definition). 'ours' = plugin defaults "
          "(adaptive detector, retrospective correction); 'main' = main's crawl levels "
          "before they were chosen on the tuning half; 'previous' = the previous round's "
          "(crawl levels without the averaged statistic); 'before' = the defaults before "
          "crawling had levels of its own; 'shoe G' = fixed SHOE threshold G "
          "with PyShoe's filter settings; 'opt shoe'/'opt best' = per-trial-optimal errors "
          "stored in the files. Split: tuning (even) / held-out (odd); motion: "
          "foot_imu_datasets.vicon_motion.\n")
    cols = ["ours", "main", "previous", "before", "no retro", "shoe 1e+08"]
    print(f"{'#':>2} {'trial':20s} {'split':5s} {'motion':9s} " + " ".join(f"{c:>10s}" for c in cols)
          + f" {'opt shoe':>9s} {'opt best':>9s}")
    for i, (tr, r) in enumerate(zip(trials, rows)):
        print(f"{i:2d} {tr.path.stem:20s} {split(i):5s} {motions[i]:9s} "
              + " ".join(f"{r[c].armse:10.3f}" for c in cols)
              + f" {stored_shoe[i]:9.3f} {stored_best[i]:9.3f}")

    def summary(name: str, values: np.ndarray) -> None:
        print(f"  {name:46s} mean {values.mean():6.3f}  median {np.median(values):6.3f}  "
              f"tuning {values[0::2].mean():7.4f}  held-out {values[1::2].mean():7.4f}  "
              f"max {values.max():6.3f}")

    print(f"\nSummary over the {len(trials)} trials [m]:")
    for k in variants:
        summary(f"ours: {k}", np.array([r[k].armse for r in rows]))
    for g in fixed:
        summary(f"fixed SHOE G={g:.0e} (PyShoe filter)", np.array([r[f'shoe {g:.0e}'].armse
                                                                      for r in rows]))
    summary("stored per-trial-optimal SHOE (tuned on truth)", stored_shoe)
    summary("stored per-trial best of 5 detectors", stored_best)
    for key in ("ours", "main", "previous", "before"):
        motion_summary(trials, rows, motions, key)
    vert = {k: np.array([r[k].vertical for r in rows]) for k in variants}
    print("\nVertical: mean |dz| against VICON height [m]: "
          + ", ".join(f"{k} {v.mean():.3f}" for k, v in vert.items()))

    print("\nIndoor walks: error at the surveyed strides, rigid fit on the first "
          f"{N_ALIGN} strides [m, % of distance]; height: mean and max |z| at the strides [m] "
          "(the floors are level), and per 100 m of walk the height at the last stride "
          "(the drift) and the largest\n")
    print(f"{'walk':8s} {'dist':>6s} | {'ours m':>7s} {'%':>5s} {'final':>6s} {'height':>6s} "
          f"{'max':>5s} {'end/100m':>8s} {'max/100m':>8s} | {'before %':>8s} {'height':>6s} "
          f"{'max':>5s} {'end/100m':>8s} | {'PyShoe m':>8s} {'%':>5s} {'final':>6s} | "
          f"{'SHOE 1e8 %':>10s}")
    acc = {k: [] for k in ("ours", "before", "py", "fixed", "h", "hmax", "bh", "bhmax", "per100",
                           "bper100", "end100", "bend100")}
    for w in walks:
        o = eval_walk(ours, w)
        b = eval_walk(BEFORE, w)
        p = pyshoe_walk(w)
        f = eval_walk(fixed[1e8], w)
        per100, bper100 = 100 * o.height_max / o.distance, 100 * b.height_max / b.distance
        end100, bend100 = 100 * o.height_end / o.distance, 100 * b.height_end / b.distance
        print(f"{w.path.stem:8s} {o.distance:6.1f} | {o.mean:7.2f} {o.percent:5.2f} {o.final:6.2f} "
              f"{o.height:6.2f} {o.height_max:5.2f} {end100:8.2f} {per100:8.2f} | "
              f"{b.percent:8.2f} {b.height:6.2f} {b.height_max:5.2f} {bend100:8.2f} | "
              f"{p.mean:8.2f} {p.percent:5.2f} {p.final:6.2f} | {f.percent:10.2f}")
        for k, v in (("ours", o.percent), ("before", b.percent), ("py", p.percent),
                     ("fixed", f.percent), ("h", o.height), ("hmax", o.height_max),
                     ("bh", b.height), ("bhmax", b.height_max), ("per100", per100),
                     ("bper100", bper100), ("end100", end100), ("bend100", bend100)):
            acc[k].append(v)
    m = {k: float(np.mean(v)) for k, v in acc.items()}
    print(f"{'mean':8s} {'':6s} | {'':7s} {m['ours']:5.2f} {'':6s} {m['h']:6.2f} {m['hmax']:5.2f} "
          f"{m['end100']:8.2f} {m['per100']:8.2f} | {m['before']:8.2f} {m['bh']:6.2f} "
          f"{m['bhmax']:5.2f} {m['bend100']:8.2f} | {'':8s} {m['py']:5.2f} {'':6s} | "
          f"{m['fixed']:10.2f}")
    better = sum(a < b for a, b in zip(acc["ours"], acc["py"]))
    print(f"\nours beats the stored PyShoe trajectory on {better} of {len(walks)} walks; "
          f"mean {m['ours']:.2f} % vs {m['py']:.2f} % (before: {m['before']:.2f} %); "
          f"vertical drift per 100 m, worst walk: {max(acc['end100']):.2f} m at the end "
          f"(before {max(acc['bend100']):.2f} m), {max(acc['per100']):.2f} m at most "
          f"(before {max(acc['bper100']):.2f} m)")
    print(f"({time.perf_counter() - t0:.0f} s)")


# -- integrity ----------------------------------------------------------------------------
#: The evaluation's alignment: the truth's first this many metres fit the frame.
FIT_DISTANCE = 5.0


def fit_count(truth: np.ndarray) -> int:
    """Poses the start frame is fitted on: up to and including the first one at least
    FIT_DISTANCE metres along the true path ``truth`` (K, 2). (Up to the last one short
    of it, as before, a run whose first step is longer had only rest poses to fit: no
    direction, a frame turned at random.)"""
    walked = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(truth, axis=0).T))))
    return int(np.searchsorted(walked, FIT_DISTANCE)) + 1


def step_poses(params: ZuptInsParams, res: BlockResult, own_cov_only: bool = False,
               clips: ClipLog | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(t (K,), position (K, 3), covariance (K, 4, 4)) of the plugin's ``pose`` output
    (INS frame) from the engine's events: its StepTracker and PoseUncertainty, each step
    told its share of saturated samples from ``clips`` (None: none saturated); with
    ``own_cov_only`` the filter's covariance alone (what the poses carried before)."""
    errors = params.odometry.errors()
    tracker = StepTracker(params.gait.thresholds(), errors)
    unc = params.integrity.uncertainty(errors)
    steps = [tracker.step(ev) for ev in res.events]
    covs = [st.cov_abs if own_cov_only
            else unc.step(st, clips.share(st.t_start, st.t) if clips else 0.0)
            for st in steps]
    return (np.array([st.t for st in steps]), np.array([st.position for st in steps]),
            np.array(covs))


#: ``--integrity``'s "as it was" rows: the radius may shrink without a fix and a step
#: faster than anyone runs adds nothing (``integrity.hold_peak``, ``integrity.max_speed``).
AS_IT_WAS = {"integrity": {"hold_peak": False, "max_speed": None}}


def integrity_errors(params: ZuptInsParams, est: np.ndarray, cov: np.ndarray,
                     truth: np.ndarray, n_fit: int) -> TrackErrors:
    """The evaluation's error series of poses ``est`` (K, >=2) with covariances ``cov``
    (K, 4, 4) against ``truth`` (K, >=2) at the same instants, after the 2D rigid fit on
    the first ``n_fit`` (the covariances turned with it)."""
    n = max(2, min(n_fit, len(est)))
    rot, trans = rigid_fit_2d(est[:n, :2], truth[:n, :2])
    dxy = est[:, :2] @ rot.T + trans - truth[:, :2]
    rot4 = np.eye(4)
    rot4[:2, :2] = rot
    cov = rot4 @ cov @ rot4.T
    radius = np.array([gaussian_protection_radius(c[:2, :2], params.integrity.containment)
                       for c in cov])
    ok = np.array([trusted(r, params.integrity) for r in radius])
    return TrackErrors("ff", np.arange(len(est), dtype=float), np.hypot(*dxy.T),
                       np.full(len(est), np.nan), np.full(len(est), np.nan),
                       path_length(truth), mahalanobis2=horizontal_mahalanobis2(dxy, cov),
                       protection=radius, trusted=ok)


def walk_integrity(params: ZuptInsParams, w: IndoorWalk, own_cov_only: bool = False
                   ) -> TrackErrors:
    """The step poses nearest each surveyed stride, fitted on the first N_ALIGN strides."""
    res, _ = run(params, w.ts, w.imu)
    t, pos, cov = step_poses(params, res, own_cov_only)
    ts = w.ts[w.stride_index]
    near = np.clip(np.searchsorted(t, ts), 1, len(t) - 1)
    near = np.where(np.abs(t[near - 1] - ts) < np.abs(t[near] - ts), near - 1, near)
    return integrity_errors(params, pos[near], cov[near], w.gcp, N_ALIGN)


def trial_integrity(params: ZuptInsParams, tr: ViconTrial, own_cov_only: bool = False
                    ) -> TrackErrors:
    """The step poses against the VICON foot at the same samples, fitted on the truth's
    first FIT_DISTANCE metres (``fit_count``)."""
    res, _ = run(params, tr.ts, tr.imu)
    t, pos, cov = step_poses(params, res, own_cov_only)
    at = np.minimum(np.searchsorted(tr.ts, t), len(tr.ts) - 1)
    truth = tr.gt[at, :2]
    return integrity_errors(params, pos, cov, truth, fit_count(truth))


def integrity_row(name: str, errs: list) -> None:
    """One table row: the evaluation's integrity figures pooled over ``errs``, and the
    worst recording's trusted-while-off share."""
    pooled = TrackErrors("ff", *(np.concatenate([getattr(e, k) for e in errs]) for k in
                                 ("t", "horizontal", "vertical", "floor_ok")),
                         sum(e.distance_m for e in errs),
                         mahalanobis2=np.concatenate([e.mahalanobis2 for e in errs]),
                         protection=np.concatenate([e.protection for e in errs]),
                         trusted=np.concatenate([e.trusted for e in errs]))
    f = integrity_figures(pooled)
    worst = max(integrity_figures(e)["trusted_off_fraction"] for e in errs)
    nees = [integrity_figures(e)["nees_xy"] for e in errs]
    print(f"| {name} | {len(errs)} | {len(pooled.t)} | {f['nees_xy']:.2f} (median "
          f"{np.median(nees):.2f}) | {f['ellipse95_containment']:.3f} | "
          f"{f['protection_containment']:.3f} | {f['trusted_fraction']:.3f} | "
          f"{100 * f['trusted_off_fraction']:.1f} % (worst {100 * worst:.1f} %) |")


def report_integrity(trials: list[ViconTrial], walks: list[IndoorWalk]) -> None:
    """NEES, ellipse and protection-radius containment of the ``pose`` output, beside
    the covariance as it was (``AS_IT_WAS``), the poses counting the odometry's spread of the lasting drift rate (not their own,
    ``integrity.drift_rate_sigma``) and the filter's own covariance alone ("before": what
    the poses carried), the same runs; the tuning and held-out halves apart."""
    now, as_it_was = ZuptInsParams(), ZuptInsParams(**AS_IT_WAS)
    odometry_drift = ZuptInsParams(integrity={"drift_rate_sigma": None})
    print("| data | covariance | recordings | poses | NEES x,y (2 if consistent; median of "
          "the recordings') | 95 % ellipse holds the truth | error within the protection "
          "radius (99 % promised) | trusted | trusted while > 3 m off (worst recording) |")
    print("|---|---|---|---|---|---|---|---|---|")
    tuning = set(range(len(walks))[WALK_TUNING])
    motions = [vicon_motion(tr) for tr in trials]
    for params, own, label in ((now, False, "now"), (as_it_was, False, "as it was"),
                               (odometry_drift, False, "odometry's drift rate"),
                               (now, True, "before")):
        for half, held in (("tuning", False), ("held out", True)):
            integrity_row(f"indoor walks, {half} | {label}", [
                walk_integrity(params, w, own) for i, w in enumerate(walks)
                if (i not in tuning) == held])
        for motion in VICON_MOTIONS:
            for half in ("tune", "held"):
                errs = [trial_integrity(params, tr, own) for i, (tr, m) in
                        enumerate(zip(trials, motions)) if m == motion and split(i) == half]
                integrity_row(f"VICON {motion}, {half} | {label}", errs)


# -- public recordings (not on this machine: give their folders) ---------------------------
def recording_arrays(path: Path) -> tuple[dict[str, tuple], list]:
    """IMU arrays per device (t, accel, gyro; repeated samples dropped, as the sensor
    does) and the truth messages of a recording, read by the recording source's readers."""
    from firenav_framework.formats.base import ReadOptions
    from firenav_framework.sources.readers import find_reader

    imu: dict[str, list] = {}
    truth = []
    for port, msg in find_reader(path)(path, ReadOptions()):
        if port == "imu":
            imu.setdefault(msg.device, []).append(msg)
        elif port == "truth":
            truth.append(msg)
    out = {}
    for device, blocks in imu.items():
        t = np.concatenate([b.time for b in blocks])
        keep = np.concatenate(([True], np.diff(t) > 0))
        out[device] = (t[keep], np.concatenate([b.accel for b in blocks])[keep],
                       np.concatenate([b.gyro for b in blocks])[keep])
    return out, truth


def run_flu(params: ZuptInsParams, t: np.ndarray, accel: np.ndarray, gyro: np.ndarray
            ) -> np.ndarray:
    """Full-rate positions of the INS on samples already in FLU (z-up devices)."""
    rate = 1.0 / float(np.median(np.diff(t)))
    eng = InsEngine(params.detector_config(rate), params.filter_config(rate))
    res = BlockResult.concat([eng.process(t, accel, gyro), eng.finish()])
    pos = correct_positions(res.states[:, eskf.O_T], res.states[:, eskf.O_POS:eskf.O_POS + 3],
                            res.events)
    return pos[res.states[:, eskf.O_ALIGNED] > 0]


#: x-io Gait-Tracking README: "the final displacement of the foot is 82 mm for a ~25 m
#: walk (short_walk.csv), and 421 mm for a ~60 m walk (long_walk.csv)" (their script, 3D).
XIO_PUBLISHED = {"short_walk.csv": 0.082, "long_walk.csv": 0.421}


def report_xio(folder: Path) -> None:
    """Closure of the two Gait-Tracking loops (they end where they start)."""
    print(f"\nx-io Gait-Tracking loops ({folder}): distance between the first and last "
          "position [m], horizontal / 3D; their script's published 3D figure beside")
    for name, published in XIO_PUBLISHED.items():
        path = folder / name
        if not path.is_file():
            print(f"  {name}: not found")
            continue
        (t, accel, gyro), = recording_arrays(path)[0].values()
        row = []
        for key, params in (("ours", ZuptInsParams()), ("before", BEFORE)):
            pos = run_flu(params, t, accel, gyro)
            d = pos[-1] - pos[0]
            row.append(f"{key} {np.hypot(d[0], d[1]):.3f} / {np.linalg.norm(d):.3f}")
        print(f"  {name:15s} {', '.join(row)}; x-io {published:.3f}")


#: Constrained-ZUPT-FGO results/statistics_report_hor.csv: mean horizontal error [m]
#: (right foot, left foot) of their EKF-ZUPT and FGO-ZUPT without position measurements.
ZUPT_FGO_PUBLISHED = {"EKF-ZUPT": (1.310, 3.338), "FGO-ZUPT": (0.446, 1.788)}


def report_zupt_fgo(folder: Path) -> None:
    """Both feet of Constrained-ZUPT-FGO's measData against positionGt.csv: the mean
    horizontal error over every 60 Hz epoch after a 2D rigid fit on the first 5 steps'
    worth of track (3 s after the start of navigation), beside their published figures."""
    print(f"\nConstrained-ZUPT-FGO measData ({folder}): mean horizontal error [m] at every "
          "epoch, rigid fit on the first 3 s of motion")
    mine = {}
    for foot in ("Right", "Left"):
        path = folder / f"imuMeas{foot}.csv"
        if not path.is_file():
            print(f"  {path.name}: not found")
            return
        arrays, truth = recording_arrays(path)
        (t, accel, gyro), = arrays.values()
        tt = np.array([m.t for m in truth])
        gt = np.array([m.position[:2] for m in truth])
        for key, params in (("ours", ZuptInsParams()), ("before", BEFORE)):
            rate = 1.0 / float(np.median(np.diff(t)))
            eng = InsEngine(params.detector_config(rate), params.filter_config(rate))
            res = BlockResult.concat([eng.process(t, accel, gyro), eng.finish()])
            pos = correct_positions(res.states[:, eskf.O_T],
                                    res.states[:, eskf.O_POS:eskf.O_POS + 3], res.events)
            ok = res.states[:, eskf.O_ALIGNED] > 0
            te, pe = res.states[ok, eskf.O_T], pos[ok, :2]
            g = np.column_stack([np.interp(te, tt, gt[:, i]) for i in (0, 1)])
            moving = np.flatnonzero(np.hypot(*(g - g[0]).T) > 0.3)
            fit = slice(0, moving[0] + int(3 * rate)) if len(moving) else slice(None)
            R, tr = rigid_fit_2d(pe[fit], g[fit])
            mine[(foot, key)] = float(np.mean(np.hypot(*(pe @ R.T + tr - g).T)))
    for key in ("ours", "before"):
        print(f"  {key:10s} right {mine[('Right', key)]:.3f}, left {mine[('Left', key)]:.3f}")
    for name, (right, left) in ZUPT_FGO_PUBLISHED.items():
        print(f"  {name:10s} right {right:.3f}, left {left:.3f} (published, their own alignment)")


def heading_sigma(params: ZuptInsParams, w: IndoorWalk) -> tuple[float, float, float, float]:
    """(duration [s], heading drift [deg/s], published heading sigma at the end [deg]:
    the increments' alone and with the drift rate's) of a walk: the odometry's heading
    variances summed over its steps, plus (published drift-rate sigma * duration)^2."""
    from firenav_framework.simulator.recordings import heading_drift

    res, pos = run(params, w.ts, w.imu)
    fit = heading_drift(pos[w.stride_index, :2], w.gcp, w.ts[w.stride_index], n_align=N_ALIGN)
    tracker = StepTracker(params.gait.thresholds(), params.odometry.errors())
    steps = [tracker.step(ev) for ev in res.events]
    duration = steps[-1].t - steps[0].t_start
    increments = sum(st.cov[3, 3] for st in steps)
    drift = (params.odometry.yaw_drift_rate_sigma * duration) ** 2
    return (duration, fit.drift_dps, math.degrees(math.sqrt(increments)),
            math.degrees(math.sqrt(increments + drift)))


def report_heading(walks: list[IndoorWalk]) -> None:
    params = ZuptInsParams()
    print("| walk | half | duration [s] | drift [deg/s] | heading lost [deg] | published sigma "
          "[deg] increments alone / with the drift rate | drift / sigma before / now |")
    print("|---|---|---|---|---|---|---|")
    z = []
    for i, w in enumerate(walks):
        dur, drift, sig0, sig = heading_sigma(params, w)
        lost = abs(drift) * dur
        z.append(lost / sig)
        half = "tuning" if i in range(len(walks))[WALK_TUNING] else "held out"
        print(f"| {w.path.stem} | {half} | {dur:.0f} | {drift:+.3f} | {lost:.1f} | "
              f"{sig0:.2f} / {sig:.1f} | {lost / sig0:.1f} / {lost / sig:.2f} |")
    print(f"rms drift/sigma now {math.sqrt(np.mean(np.square(z))):.2f}, max {max(z):.2f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tune", action="store_true", help="redo the detector tuning (minutes)")
    ap.add_argument("--heading", action="store_true", help="odometry heading sigma against "
                    "the walks' heading drift")
    ap.add_argument("--integrity", action="store_true", help="NEES, ellipse and protection "
                    "radius containment of the pose output")
    ap.add_argument("--xio", type=Path, help="folder of x-io Gait-Tracking's short_walk.csv "
                    "and long_walk.csv (the project's repository)")
    ap.add_argument("--zupt-fgo", type=Path, help="Constrained-ZUPT-FGO's measData folder")
    args = ap.parse_args()
    root = data_dir()
    if not root.is_dir():
        sys.exit(f"datasets not found at {root} (set FIRENAV_SHARED_DATA)")
    trials = [load_vicon_trial(p) for p in sorted((root / "pyshoe-vicon").glob("*.mat"))]
    walks = [load_indoor_walk(p) for p in sorted((root / "indoor-walks").glob("*.mat"))]
    if args.heading:
        report_heading(walks)
    elif args.integrity:
        report_integrity(trials, walks)
    elif args.tune:
        tune(trials, walks)
    else:
        report(trials, walks)
    if args.xio:
        report_xio(args.xio)
    if args.zupt_fgo:
        report_zupt_fgo(args.zupt_fgo)


if __name__ == "__main__":
    main()
