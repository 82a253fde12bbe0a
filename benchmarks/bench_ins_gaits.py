"""The foot INS walking, crawling and running, on the simulator and the real VICON trials.

    .venv/bin/python benchmarks/bench_ins_gaits.py                  # report seeds 1000-1019
    .venv/bin/python benchmarks/bench_ins_gaits.py --seeds tuning   # seeds 100-139
    .venv/bin/python benchmarks/bench_ins_gaits.py --field          # the field scenarios
    .venv/bin/python benchmarks/bench_ins_gaits.py --tune           # choose the crawl levels
    .venv/bin/python benchmarks/bench_ins_gaits.py --integrity --seeds fresh --gaits run,walk
                                    # covariance, radius, trusted (seeds 2000-2019)
    .venv/bin/python benchmarks/bench_ins_gaits.py --integrity --seeds 3000-3019
                                    # any range A-B of seeds, both ends included
    .venv/bin/python benchmarks/bench_ins_gaits.py --integrity --per-run --seeds tuning --gaits run
                                    # and each run's figures (seed, ellipse, trusted while off)

Three scenarios of ``benchmarks/scenarios`` (the same corridor, the IMU of the real
recordings, as worn): ``ins_walk`` (54 m), ``ins_crawl`` (kneel, then 34 m on hands and
knees), ``ins_run`` (54 m at 3 m/s, the accelerometer saturating); and the bundled
``zupt_multifloor`` (ten minutes over three storeys, up and down stairs) for the
level-floor height handling. Each seed draws the person, the IMU errors and the gait
jitter afresh. Per run, from the INS's step events against the true foot position at
the same instants:

* ``steps``: steps the INS found per true stride of the instrumented foot;
* ``distance``: the INS's path length over the true one, both from step to step (1 =
  right);
* ``error/m``: the mean horizontal error at the steps after a 2D rigid fit on the steps
  of the first 5 m travelled (what an entrance fix would give a live system), per metre
  of true path;
* ``height error``: mean |error| of the step heights (both taken from the start) and
  the error at the last step.

The real rows: the PyShoe VICON trials by ``foot_imu_datasets.vicon_motion`` (walk 25,
run 23, crawl 4), the shape error per metre (``zupt_ins.metrics.shape_error_per_distance``:
whole-track rigid fit, mean error over the VICON path) per trial. The crawls are short
(4-9 m against the walks' longer loops) and part of any error does not grow with the
distance, so the crawl/walk ratio is given twice: over whole trials, and "at equal
distance": each crawl over the walking trials cut at that crawl's path length.

Printed per gait: median and [min, max] over the seeds (trials), for the plugin
defaults ("now"), main's crawl levels before they were chosen on the tuning half
("main", ``bench_ins_real_data.MAIN``) and the defaults of the previous round ("before",
``bench_ins_real_data.PREVIOUS``), in the same run; then each gait's error/m over
walking's (the issue's target for crawling: at most 3x).

``--tune`` chooses the crawl levels (``detector.crawl``) on the simulator's tuning seeds
100-139 and the tuning half of the VICON trials (``bench_ins_real_data``'s split: even
index in name order; two of the four crawls, 14 walks). A setting must leave no tuning
seed more than 8 % off in distance; among those whose two crawl/walk ratios (VICON at
equal distance, simulator median error/m) are at most 3x, the lowest mean ARMSE of the
tuning crawls is chosen. The report seeds and the held-out trials play no part.
"""
from __future__ import annotations

import argparse
import itertools
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "benchmarks"))

from bench_ins_real_data import (  # noqa: E402
    AS_IT_WAS, MAIN, PREVIOUS, WALK_TUNING, data_dir, eval_trial, fit_count, integrity_errors,
    integrity_row, run, split, step_poses)
from firenav_framework.evaluation.metrics import integrity_figures  # noqa: E402
from firenav_framework.simulator import simulate  # noqa: E402
from firenav_framework.yaml_locations import ConfigError  # noqa: E402
from firenav_framework.sources.readers.foot_imu_datasets import (  # noqa: E402
    load_vicon_trial, vicon_motion)
from firenav_plugins.estimators.zupt_ins import BlockResult, InsEngine, ZuptInsParams  # noqa: E402
from firenav_plugins.estimators.zupt_ins import eskf  # noqa: E402
from firenav_plugins.estimators.zupt_ins.clipping import ClipLog  # noqa: E402
from firenav_plugins.estimators.zupt_ins.metrics import (  # noqa: E402
    path_length, shape_error_per_distance, stride_errors)

SCENARIOS: dict[str, Path | str] = {
    **{g: REPO / "benchmarks" / "scenarios" / f"ins_{g}.yaml" for g in ("walk", "crawl", "run")},
    "stairs": "zupt_multifloor",    # bundled: ten minutes over three storeys
}
#: ``--field``: the bundled field scenarios with crawling or running (uncalibrated
#: mid-grade IMUs, no still start, furniture): the same figures, no real rows.
FIELD: dict[str, Path | str] = {"crawl_search": "field_crawl_search",
                                "corridor_run": "field_corridor_run",
                                "multifloor_long": "field_multifloor_long"}
SEEDS = {"tuning": range(100, 140), "report": range(1000, 1020), "fresh": range(2000, 2020)}
#: ``--integrity``'s "no fast gait" row: the poses' covariance without the fast-gait errors
#: (``pose_uncertainty.FastGaitErrors``), as it was before they were counted.
NO_FAST_GAIT = {"integrity": {"speed_drift_sigma": 0.0, "long_swing_sigma": 0.0}}
#: ``--integrity``'s "odometry's drift rate" row: the poses count the lasting heading drift
#: rate with the odometry's spread (``odometry.yaw_drift_rate_sigma``), not their own.
ODOMETRY_DRIFT = {"integrity": {"drift_rate_sigma": None}}
#: ``--integrity``'s "clipped steps vouched for" row: a step with many saturated samples
#: is not taken for lost (``integrity.max_clipped`` off), as before it was counted.
NO_CLIPPED = {"integrity": {"max_clipped": None}}
#: device axes of the simulator's IMU frames -> FLU
TO_FLU = {"FRD": np.array([1.0, -1.0, -1.0]), "FLU": np.ones(3)}
ALIGN_DISTANCE = 5.0   # [m] the steps of the first this many metres fit the start pose

#: ``--tune`` grid of the crawl levels (log10 T, kappa, decades, s, s); ``low`` and
#: ``prominence`` changed nothing in a wider grid (low 5.0-6.0) and are held.
CRAWL_GRID = {"low": [5.5], "high": [7.0, 7.2, 7.4], "kappa": [0.2, 0.35, 0.5, 0.65],
              "prominence": [1.0], "min_stance": [0.01, 0.025],
              "smoothing": [0.0, 0.1, 0.15, 0.2, 0.25, 0.3]}
#: Tuning runs further off in distance than this disqualify a setting.
DISTANCE_TOLERANCE = 0.08
#: The issue's goal for crawling: error per distance at most this times walking's.
RATIO_GOAL = 3.0


@dataclass
class Recording:
    """One simulated run, ready for the INS: FLU samples and the true foot track."""

    t: np.ndarray
    accel: np.ndarray
    gyro: np.ndarray
    foot: np.ndarray          # (N, 3) true foot (IMU point) position at every sample [m]
    strides: int              # true strides of the instrumented foot
    saturated: np.ndarray     # (N,) bool: accelerometer or gyro at full scale (the flag)


@dataclass
class Score:
    steps: float              # steps found per true stride
    distance: float           # INS path / true path
    error: float              # mean error after the 5 m fit, per metre of true path
    vertical: float           # mean |height error| at the steps [m] (heights from the start)
    vertical_end: float       # |height error| at the last step [m]


def record(gait: str | Path, seed: int) -> Recording:
    """One run of a scenario named in SCENARIOS or FIELD, or of a scenario file."""
    r = simulate({**SCENARIOS, **FIELD}.get(str(gait), gait), seed)
    rec, truth = r.imu["ff1"], r.truth["ff1"]
    axes = TO_FLU[rec.frame]
    return Recording(rec.time, rec.accel * axes, rec.gyro * axes, truth.foot.position,
                     len(truth.strides.t0), rec.saturated)


def score(params: ZuptInsParams, rec: Recording) -> Score:
    rate = 1.0 / float(np.median(np.diff(rec.t)))
    eng = InsEngine(params.detector_config(rate), params.filter_config(rate))
    res = BlockResult.concat([eng.process(rec.t, rec.accel, rec.gyro), eng.finish()])
    steps = res.events[res.events[:, eskf.E_KIND] == eskf.EVENT_STEP]
    if len(steps) < 3:
        return Score(len(steps) / rec.strides, 0.0, float("inf"), float("inf"), float("inf"))
    at = np.minimum(np.searchsorted(rec.t, steps[:, eskf.E_T]), len(rec.t) - 1)
    truth, est = rec.foot[at, :2], steps[:, eskf.E_POS:eskf.E_POS + 2]
    true_path = path_length(truth)
    walked = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(truth, axis=0).T))))
    n_align = max(2, int(np.searchsorted(walked, ALIGN_DISTANCE)))
    err = stride_errors(est, truth, n_align=n_align, distance=true_path)
    dz = np.abs((steps[:, eskf.E_POS + 2] - steps[0, eskf.E_POS + 2])
                - (rec.foot[at, 2] - rec.foot[at[0], 2]))
    return Score(len(steps) / rec.strides, path_length(est) / true_path, err.mean_percent / 100,
                 float(dz.mean()), float(dz[-1]))


def spread(values: list[float], fmt: str = "{:.3f}") -> str:
    v = np.asarray(values)
    return (f"{fmt.format(np.median(v))} [{fmt.format(v.min())}, {fmt.format(v.max())}]")


def vicon_trials() -> dict[str, list]:
    """The VICON trials by class (``walk``, ``run``, ``crawl``, ``irregular``)."""
    out: dict[str, list] = {}
    for path in sorted((data_dir() / "pyshoe-vicon").glob("*.mat")):
        tr = load_vicon_trial(path)
        out.setdefault(vicon_motion(tr), []).append(tr)
    return out


def shape_up_to(params: ZuptInsParams, tr, length: float) -> float | None:
    """Shape error per metre of a VICON trial over its first ``length`` metres of path
    (measured as ``shape_error_per_distance`` measures it), or None when it is shorter."""
    _, pos = run(params, tr.ts, tr.imu)
    sub = tr.gt[::10, :2]
    walked = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(sub, axis=0).T))))
    k = int(np.searchsorted(walked, length))
    if k >= len(sub) - 1:
        return None
    n = 10 * k + 1
    return shape_error_per_distance(pos[:n], tr.gt[:n])


def vicon_ratios(params: ZuptInsParams, crawls: list, walks: list) -> tuple[float, float]:
    """Crawl/walk shape error per metre of the VICON trials: (whole trials, mean over the
    crawls of each over the walking trials cut at its path length)."""
    crawl = [eval_trial(params, tr) for tr in crawls]
    whole = float(np.mean([c.shape for c in crawl])
                  / np.mean([eval_trial(params, tr).shape for tr in walks]))
    equal = []
    for c in crawl:
        cut = [x for x in (shape_up_to(params, tr, c.path) for tr in walks) if x is not None]
        equal.append(c.shape / float(np.mean(cut)))
    return whole, float(np.mean(equal))


def report(seeds: range, field: bool = False) -> None:
    t0 = time.perf_counter()
    configs = {"now": ZuptInsParams(), "main": MAIN, "before": PREVIOUS}
    scores: dict[tuple[str, str], list[Score]] = {}
    gaits = FIELD if field else SCENARIOS
    for gait in gaits:
        for seed in seeds:
            rec = record(gait, seed)
            for name, params in configs.items():
                scores.setdefault((gait, name), []).append(score(params, rec))
    print(f"Simulated gaits, seeds {seeds.start}-{seeds.stop - 1} ({len(seeds)} runs per row): "
          "median [min, max]\n")
    print(f"{'scenario':15s} {'defaults':8s} | {'steps/stride':>22s} | {'distance ratio':>22s} | "
          f"{'error per metre [%]':>22s} | {'height error [m]':>22s} | {'at the end [m]':>22s}")
    for (gait, name), s in scores.items():
        print(f"{gait:15s} {name:8s} | {spread([x.steps for x in s]):>22s} | "
              f"{spread([x.distance for x in s]):>22s} | "
              f"{spread([100 * x.error for x in s], '{:.2f}'):>22s} | "
              f"{spread([x.vertical for x in s], '{:.2f}'):>22s} | "
              f"{spread([x.vertical_end for x in s], '{:.2f}'):>22s}")
    if field:
        print(f"({time.perf_counter() - t0:.0f} s)")
        return
    print("\nerror per metre over walking's (median over seeds of each):")
    for name in configs:
        walk = np.median([x.error for x in scores[("walk", name)]])
        print(f"  {name:8s} " + ", ".join(
            f"{gait} {np.median([x.error for x in scores[(gait, name)]]) / walk:.1f}x"
            for gait in SCENARIOS))
    trials = vicon_trials()
    print("\nReal VICON trials: shape error per metre [%], median [min, max] over the trials")
    for name, params in configs.items():
        for motion in ("walk", "run", "crawl"):
            res = [eval_trial(params, tr) for tr in trials[motion]]
            print(f"  {motion:6s} {name:8s} n={len(res):2d} "
                  f"{spread([100 * r.shape for r in res], '{:.2f}'):>22s}  ARMSE "
                  f"{spread([r.armse for r in res]):>22s} m  path "
                  f"{spread([r.path for r in res], '{:.1f}')} m")
        whole, equal = vicon_ratios(params, trials["crawl"], trials["walk"])
        run_ratio = (np.mean([eval_trial(params, tr).shape for tr in trials["run"]])
                     / np.mean([eval_trial(params, tr).shape for tr in trials["walk"]]))
        print(f"  {name:8s} crawl/walk {whole:.2f}x over whole trials, {equal:.2f}x at equal "
              f"distance; run/walk {run_ratio:.2f}x")
    print(f"({time.perf_counter() - t0:.0f} s)")


# -- tuning -----------------------------------------------------------------------------
def tuning_half() -> dict[str, list]:
    """The VICON trials of the tuning half (even index in name order, as
    ``bench_ins_real_data --tune`` splits them), by class."""
    out: dict[str, list] = {}
    for i, path in enumerate(sorted((data_dir() / "pyshoe-vicon").glob("*.mat"))):
        if split(i) == "tune":
            tr = load_vicon_trial(path)
            out.setdefault(vicon_motion(tr), []).append(tr)
    return out


def tune() -> None:
    """Choose the crawl levels on the tuning half only (see the module docstring)."""
    trials = tuning_half()
    v_crawl, v_walk = trials["crawl"], trials["walk"]
    seeds = SEEDS["tuning"]
    s_crawl = [record("crawl", s) for s in seeds]
    s_walk = [record("walk", s) for s in seeds]
    base = ZuptInsParams()
    # the crawl levels do not act on upright feet: walking is scored once
    walk_shape = float(np.mean([eval_trial(base, tr).shape for tr in v_walk]))
    walk_error = float(np.median([score(base, rec).error for rec in s_walk]))
    paths = [path_length(tr.gt[::10]) for tr in v_crawl]
    walk_cut = [float(np.mean([x for x in (shape_up_to(base, tr, length) for tr in v_walk)
                               if x is not None])) for length in paths]
    reference = float(np.mean([eval_trial(PREVIOUS, tr).armse for tr in v_crawl]))
    print(f"VICON tuning half: {len(v_crawl)} crawl trials "
          f"({', '.join(tr.path.stem for tr in v_crawl)}), {len(v_walk)} walking trials; "
          f"simulator seeds {seeds.start}-{seeds.stop - 1}. Walking: VICON shape/m "
          f"{100 * walk_shape:.2f} % (cut at the crawls' lengths: "
          f"{', '.join(f'{100 * w:.2f} %' for w in walk_cut)}), simulator error/m "
          f"{100 * walk_error:.2f} %; the crawls' ARMSE with the previous levels "
          f"{reference:.4f} m")
    rows = []
    for values in itertools.product(*CRAWL_GRID.values()):
        crawl = dict(zip(CRAWL_GRID, values))
        if crawl["low"] > crawl["high"]:
            continue
        params = ZuptInsParams(detector={"crawl": crawl})
        res = [eval_trial(params, tr) for tr in v_crawl]
        armse = float(np.mean([r.armse for r in res]))
        whole = float(np.mean([r.shape for r in res])) / walk_shape
        equal = float(np.mean([r.shape / w for r, w in zip(res, walk_cut)]))
        sim = [score(params, rec) for rec in s_crawl]
        rs = float(np.median([x.error for x in sim])) / walk_error
        off = sum(abs(x.distance - 1.0) > DISTANCE_TOLERANCE for x in sim)
        rows.append((off, armse, equal, whole, rs, crawl))
    tracked = [r for r in rows if r[0] == 0]
    goal = sorted((r for r in tracked if max(r[2], r[4]) <= RATIO_GOAL), key=lambda r: r[1])
    rest = sorted((r for r in tracked if max(r[2], r[4]) > RATIO_GOAL),
                  key=lambda r: max(r[2], r[4]))

    def show(title: str, chosen: list) -> None:
        print(title)
        for off, armse, equal, whole, rs, crawl in chosen:
            print(f"  ARMSE {armse:.4f} m  VICON {equal:5.2f}x at equal distance ({whole:5.2f}x "
                  f"whole)  simulator {rs:5.2f}x  off {off:2d}/{len(seeds)}  {crawl}")

    print(f"{len(rows)} settings, {len(tracked)} leave no tuning seed more than "
          f"{DISTANCE_TOLERANCE:.0%} off in distance (required)")
    show(f"meeting the goal (both crawl/walk ratios at most {RATIO_GOAL:g}x), by the tuning "
         f"crawls' ARMSE (the first is chosen; the previous levels: {reference:.4f} m):", goal)
    show("not meeting it, by the larger ratio (best 5):", rest[:5])
    show("the lowest tuning-crawl ARMSE of all (5):", sorted(tracked, key=lambda r: r[1])[:5])
    print(f"defaults now: {base.detector.crawl.model_dump()}")


# -- integrity ----------------------------------------------------------------------------
def sim_poses(params: ZuptInsParams, rec: Recording, own_cov_only: bool = False):
    """(t (K,), position (K, 3), covariance (K, 4, 4)) of the ``pose`` output of one
    simulated run, as the plugin makes them (``bench_ins_real_data.step_poses``, and each
    step told the share of its samples the simulator marked saturated, as ``foot_imu``
    flags them); with ``own_cov_only`` the filter's covariance alone."""
    rate = 1.0 / float(np.median(np.diff(rec.t)))
    eng = InsEngine(params.detector_config(rate), params.filter_config(rate))
    res = BlockResult.concat([eng.process(rec.t, rec.accel, rec.gyro), eng.finish()])
    clips = ClipLog()
    clips.add(rec.t, rec.saturated)
    return step_poses(params, res, own_cov_only, clips)


def sim_integrity(params: ZuptInsParams, rec: Recording, own_cov_only: bool = False,
                  poses: tuple | None = None):
    """The evaluation's error series of the ``pose`` output of one simulated run: the
    step poses (``poses``, default :func:`sim_poses`) against the true foot at the same
    instants, the frame fitted on the first 5 m (``bench_ins_real_data.fit_count``,
    ``integrity_errors``)."""
    t, pos, cov = poses or sim_poses(params, rec, own_cov_only)
    at = np.minimum(np.searchsorted(rec.t, t), len(rec.t) - 1)
    truth = rec.foot[at, :2]
    return integrity_errors(params, pos, cov, truth, fit_count(truth))


def per_run(gait: str, seeds: range, recs: list[Recording], params: ZuptInsParams) -> None:
    """``--per-run``: each run's integrity figures with the defaults, and what its steps
    look like (fastest step [m/s], longest step [s]: lost stances; largest error [m])."""
    print(f"\n{gait}, per run (defaults): seed | poses | 95 % ellipse | trusted | trusted "
          "while > 3 m off | largest error [m] | fastest step [m/s] | longest step [s]")
    for seed, rec in zip(seeds, recs):
        t, pos, cov = poses = sim_poses(params, rec)
        err = sim_integrity(params, rec, poses=poses)
        f = integrity_figures(err)
        dt = np.diff(t)
        speed = np.hypot(*np.diff(pos[:, :2], axis=0).T) / np.maximum(dt, 1e-9)
        print(f"  {seed} | {len(t)} | {f['ellipse95_containment']:.3f} | "
              f"{f['trusted_fraction']:.3f} | {100 * f['trusted_off_fraction']:.1f} % | "
              f"{err.horizontal.max():.2f} | {speed.max(initial=0.0):.2f} | "
              f"{dt.max(initial=0.0):.2f}")


def report_integrity(seeds: range, gaits: list[str] | None = None,
                     runs: bool = False) -> None:
    """``--integrity``: NEES, ellipse and protection-radius containment of the poses on
    the simulated gaits (names or scenario files), beside the covariance as it was
    (``AS_IT_WAS``), with the odometry's drift rate, without the fast-gait errors, with
    steps of many saturated samples vouched for (``NO_CLIPPED``) and the filter's own
    covariance alone (the same runs); with ``runs`` each run's figures too
    (:func:`per_run`)."""
    params, no_fast = ZuptInsParams(), ZuptInsParams(**NO_FAST_GAIT)
    as_it_was = ZuptInsParams(**AS_IT_WAS)
    odometry_drift = ZuptInsParams(**ODOMETRY_DRIFT)
    no_clipped = ZuptInsParams(**NO_CLIPPED)
    print(f"Simulated gaits, seeds {seeds.start}-{seeds.stop - 1} ({len(seeds)} runs a row)\n")
    print("| scenario | covariance | runs | poses | NEES x,y (median of the runs') | 95 % "
          "ellipse holds the truth | error within the protection radius (99 % promised) | "
          "trusted | trusted while > 3 m off (worst run) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for gait in gaits or SCENARIOS:
        recs = [record(gait, s) for s in seeds]
        for p, own, label in ((params, False, "now"), (as_it_was, False, "as it was"),
                              (odometry_drift, False, "odometry's drift rate"),
                              (no_fast, False, "no fast gait"),
                              (no_clipped, False, "clipped steps vouched for"),
                              (params, True, "filter's own")):
            integrity_row(f"{gait} | {label}", [sim_integrity(p, r, own) for r in recs])
        if runs:
            per_run(gait, seeds, recs, params)


#: ``--tune-height`` grid of the level-floor handling (``height`` group).
HEIGHT_GRID = {"level_threshold": [0.05, 0.08, 0.12], "stair_run": [0.9, 1.2, 1.5],
               "level_sigma": [0.005, 0.01, 0.02]}


def tune_height() -> None:
    """Level-floor parameters on the tuning halves: the even VICON trials (mean |dz|
    against the VICON height), walks 32/34/36/38 (height at the strides over the last
    one, per 100 m: the floors are level) and the stairs scenario's tuning seeds (mean
    height error); the objective is the sum of each over its value with the defaults."""
    from bench_ins_real_data import eval_walk, load_indoor_walk

    root = data_dir()
    trials = [load_vicon_trial(p) for p in sorted((root / "pyshoe-vicon").glob("*.mat"))][0::2]
    walks = [load_indoor_walk(p) for p in sorted((root / "indoor-walks").glob("*.mat"))][WALK_TUNING]
    stairs = [record("stairs", s) for s in SEEDS["tuning"]]

    def figures(params: ZuptInsParams) -> tuple[float, float, float]:
        vicon = float(np.mean([eval_trial(params, tr).vertical for tr in trials]))
        walk = float(np.mean([100 * eval_walk(params, w).height_max / eval_walk(params, w).distance
                              for w in walks]))
        sim = float(np.median([score(params, rec).vertical for rec in stairs]))
        return vicon, walk, sim

    base = figures(ZuptInsParams())
    print(f"defaults {ZuptInsParams().height.model_dump()}: VICON mean |dz| {base[0]:.3f} m, "
          f"walks max |z| {base[1]:.3f} m/100 m, stairs {base[2]:.3f} m")
    rows = []
    for values in itertools.product(*HEIGHT_GRID.values()):
        height = dict(zip(HEIGHT_GRID, values))
        f = figures(ZuptInsParams(height=height))
        rows.append((sum(a / b for a, b in zip(f, base)), f, height))
    rows.sort(key=lambda r: r[0])
    for total, f, height in rows[:8]:
        print(f"  {total:5.2f}  VICON {f[0]:.3f}  walks {f[1]:.3f}  stairs {f[2]:.3f}  {height}")


def seed_range(text: str) -> range:
    """``--seeds``: a named set (``tuning``, ``report``, ``fresh``) or ``A-B`` (both
    included)."""
    if text in SEEDS:
        return SEEDS[text]
    first, sep, last = text.partition("-")
    if not (sep and first.isdigit() and last.isdigit() and int(first) <= int(last)):
        raise argparse.ArgumentTypeError(
            f"--seeds {text!r}: give one of {', '.join(sorted(SEEDS))} or a range A-B, A <= B")
    return range(int(first), int(last) + 1)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=seed_range, default="report", help="tuning (100-139), "
                    "report (1000-1019), fresh (2000-2019) or a range A-B")
    ap.add_argument("--field", action="store_true", help="the field scenarios with crawling "
                    "and running instead of the gait set")
    ap.add_argument("--tune", action="store_true", help="choose the crawl levels (minutes)")
    ap.add_argument("--integrity", action="store_true", help="NEES, ellipse and protection "
                    "radius containment of the poses")
    ap.add_argument("--per-run", action="store_true", help="--integrity: each run's "
                    "figures too (seed, ellipse, trusted while off, fastest and longest step)")
    ap.add_argument("--tune-height", action="store_true", help="choose the level-floor "
                    "parameters (minutes)")
    ap.add_argument("--gaits", help="--integrity: these scenarios only (comma-separated, "
                    f"of {', '.join({**SCENARIOS, **FIELD})}, or scenario files)")
    args = ap.parse_args()
    if args.tune:
        tune()
    elif args.tune_height:
        tune_height()
    elif args.integrity:
        try:
            report_integrity(args.seeds, args.gaits.split(",") if args.gaits else None,
                             runs=args.per_run)
        except ConfigError as exc:            # an unknown name, a broken scenario file
            ap.error(f"--gaits: {exc}")
    else:
        report(args.seeds, field=args.field)


if __name__ == "__main__":
    main()
