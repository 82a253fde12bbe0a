"""Is the simulated foot IMU as hard for a ZUPT INS as real data? Real vs simulated, side by side.

    .venv/bin/python benchmarks/bench_sim_realism.py                  # report seeds 1000-1019
    .venv/bin/python benchmarks/bench_sim_realism.py --seeds 100-139  # the tuning seeds
    .venv/bin/python benchmarks/bench_sim_realism.py --markdown out.md --json out.json

The real side is every recording of ``../shared/data`` (MicroStrain 3DM-GX5-25 at
200 Hz): the eight indoor walks (surveyed footprints) and the 56 PyShoe VICON trials,
sorted into walks by pace, runs, crawls and motion in place by
:func:`firenav_framework.simulator.recordings.classify_recording` (how: its docstring;
the table of trials is printed first). The simulated side is a twin of each set: the
bundled ``indoor_walk`` scenario for the walks; for each VICON class, loops of 2.6 m
across (the capture area is 3 x 3 m) at that class's median pace and stride frequency,
as far as the class's median trial goes (error per distance depends on how far), with
the VICON trials' mount (the unit pitched 17 degrees on the shoe, flexing half as much
as the walks' strap, the shoe pivoting on the floor on the tight loops: ``VICON_MOUNT``).
Both sides go through the same code:

* **heading drift** [deg/s]: the slope of the INS's step headings against the truth's
  (:func:`~firenav_framework.simulator.recordings.heading_drift`), mean of its magnitude
  over the recordings (seeds), the INS with its defaults, and again with the gyro bias
  taken from the still start (``alignment.gyro_bias``);
* **error per distance** [%]: the INS's horizontal error at its steps after a rigid fit
  on the first 5 (``zupt_ins.metrics.stride_errors``), mean over the steps, per metre
  walked; steps are the surveyed footprints (walks; the twin: its footfalls) or the
  middles of the INS's zero-velocity runs (VICON and its twins);
* **stance quiet time** [s per stride]: time below 20 and 50 deg/s per gait cycle and the
  lowest rate of a stance (:mod:`~firenav_framework.simulator.signal_stats`), median over
  the cycles of a recording, median over the recordings (seeds);
* **crawling**: the distance the INS measures over the true distance, on the crawl
  trials and their twin, and on a 108 m simulated crawl (``search_flat_right`` crawled).

Every simulated figure is printed beside the real one with the ratio; "ok" when within
25 %. The simulator's parameters (the grade's as-worn errors, the gaits, the mounts) were
chosen on the tuning seeds 100-139; the report seeds are 1000-1019.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from bench_ins_real_data import data_dir, run  # noqa: E402
from firenav_framework.simulator import load_scenario, simulate  # noqa: E402
from firenav_framework.evaluation.seeds import parse_seeds  # noqa: E402
from firenav_framework.simulator.imu_errors import vibration_rms  # noqa: E402
from firenav_framework.simulator.mount import imu_kinematics  # noqa: E402
from firenav_framework.simulator.recordings import (classify_recording,  # noqa: E402
                                                    heading_drift)
from firenav_framework.simulator.scenario import load_scenario_text  # noqa: E402
from firenav_framework.simulator.signal_stats import stance_statistics, true_runs  # noqa: E402
from firenav_framework.sources.readers.foot_imu_datasets import (  # noqa: E402
    load_indoor_walk, load_vicon_trial)
from firenav_plugins.estimators.zupt_ins import ZuptInsParams, eskf  # noqa: E402
from firenav_plugins.estimators.zupt_ins.metrics import stride_errors  # noqa: E402

Z_DOWN_UP = np.array([0.0, 0.0, -1.0])     # the datasets' z-down unit: "up" is -z
N_ALIGN = 5
TOLERANCE = 0.25
#: VICON class -> the simulator gait its twin walks (at the class's pace and cadence).
TWIN_GAIT = {"walk_slow": "slow", "walk_normal": "walk", "walk_brisk": "brisk", "run": "run",
             "crawl": "crawl"}
CLASSES = list(TWIN_GAIT)
#: The VICON trials' mount (``MountConfig``): pitched 17 degrees, flexing 7, more damped;
#: on the capture area's tight loops (50-70 degrees of turn a stride) the shoe pivots
#: on the floor (``pivot_slide_mm``), and on all fours it rocks 3 degrees a contact.
VICON_MOUNT = {"flex_deg": 7, "damping": 0.3, "pivot_slide_mm": 25, "rock_deg": 3.0}
STILL_START_S = 3.0


@dataclass
class Figures:
    """What one recording (or one simulated run) gives."""

    name: str
    label: str = ""
    pace: float = float("nan")
    stride_hz: float = float("nan")
    drift: float = float("nan")          # |heading drift| [deg/s], INS defaults
    drift_still: float = float("nan")    # same, gyro bias from the still start
    pct: float = float("nan")            # error per distance [%]
    ratio: float = float("nan")          # INS distance / true distance
    distance: float = float("nan")       # true path at the steps [m]
    vibration: float = float("nan")      # rms specific force above 10 Hz [g]
    stance: dict = field(default_factory=dict)


def ins_params(still_s: float | None) -> ZuptInsParams:
    """The INS with its defaults, or with the gyro bias taken from ``still_s`` of rest."""
    if still_s is None:
        return ZuptInsParams()
    return ZuptInsParams(alignment={"gyro_bias": True,
                                    "duration": max(0.1, still_s - 0.3)})


def zupt_steps(res, truth_pos: np.ndarray, min_step_m: float = 0.15) -> np.ndarray:
    """Sample index of the middle of the INS's zero-velocity runs, keeping one where the
    truth has moved at least ``min_step_m`` since the last one kept (a stance the
    detector splits in two, a foot turned on the spot)."""
    starts, ends = true_runs(res.states[:, eskf.O_ZV] > 0.5)
    mid = np.clip((starts + ends) // 2, 0, len(truth_pos) - 1)
    keep, last = [], None
    for i in mid:
        if last is None or np.linalg.norm(truth_pos[i, :2] - truth_pos[last, :2]) >= min_step_m:
            keep.append(i)
            last = i
    return np.array(keep, int)


def path_length(p: np.ndarray) -> float:
    return float(np.sum(np.linalg.norm(np.diff(p[:, :2], axis=0), axis=1)))


def rms_vibration(accel: np.ndarray) -> float:
    """rms [g] over the recording of the specific force above 10 Hz (200 Hz data)."""
    return float(np.sqrt(np.mean(vibration_rms(accel, 200.0) ** 2)))


def still_time(gyro: np.ndarray, fs: float) -> float:
    """Seconds of rest at the start: until the rate first exceeds 10 deg/s."""
    over = np.flatnonzero(np.degrees(np.linalg.norm(gyro, axis=1)) > 10.0)
    return float(over[0] / fs) if len(over) else 0.0


def score_steps(t, imu, steps_fn, still: float | None) -> tuple[float, float]:
    """(|drift| deg/s, error per distance %) of the INS at its steps."""
    res, pos = run(ins_params(still), t, imu)
    idx, truth = steps_fn(res)
    fit = heading_drift(pos[idx, :2], truth, t[idx], n_align=N_ALIGN)
    err = stride_errors(pos[idx, :2], truth, n_align=N_ALIGN)
    return abs(fit.drift_dps), err.mean_percent


# -- the real recordings ---------------------------------------------------------------

def real_walks(root: Path) -> list[Figures]:
    out = []
    for p in sorted((root / "indoor-walks").glob("*.mat")):
        w = load_indoor_walk(p)
        steps = lambda res: (w.stride_index, w.gcp)  # noqa: E731
        drift, pct = score_steps(w.ts, w.imu, steps, None)
        still = still_time(w.gyro, 200.0)
        drift_still = score_steps(w.ts, w.imu, steps, still)[0] if still >= 1.0 else np.nan
        out.append(Figures(p.stem, "walk_indoor", drift=drift, drift_still=drift_still, pct=pct,
                           vibration=rms_vibration(w.accel),
                           stance=stance_statistics(w.ts, w.accel, w.gyro).summary()))
    return out


def real_vicon(root: Path) -> list[Figures]:
    out = []
    for p in sorted((root / "pyshoe-vicon").glob("*.mat")):
        v = load_vicon_trial(p)
        out.append(vicon_like(p.stem, v.ts, v.accel, v.gyro, v.gt))
    return out


def vicon_like(name: str, t, accel, gyro, truth_pos) -> Figures:
    """The figures of a recording whose truth tracks the IMU at every sample."""
    c = classify_recording(t, accel, gyro, truth_pos, Z_DOWN_UP)
    imu = np.hstack([accel, gyro])
    res, pos = run(ins_params(None), t, imu)
    idx = zupt_steps(res, truth_pos)
    f = Figures(name, c.label, c.speed_mps, c.stride_hz, vibration=rms_vibration(accel),
                stance=stance_statistics(t, accel, gyro).summary())
    if len(idx) > N_ALIGN + 3:
        fit = heading_drift(pos[idx, :2], truth_pos[idx, :2], t[idx], n_align=N_ALIGN)
        f.drift = abs(fit.drift_dps)
        f.pct = stride_errors(pos[idx, :2], truth_pos[idx, :2], n_align=N_ALIGN).mean_percent
        f.distance = path_length(truth_pos[idx])
        f.ratio = path_length(pos[idx]) / f.distance
    return f


# -- the twins -----------------------------------------------------------------------------

def loop_via(distance: float, centre=(29.0, 3.45), radius: float = 1.3, n: int = 36) -> list:
    """Way points round a circle from its east point, ``distance`` [m] along it."""
    a = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    ring = [[round(centre[0] + radius * np.cos(x), 3), round(centre[1] + radius * np.sin(x), 3)]
            for x in a]
    k = max(n // 2, int(round(distance / (2 * np.pi * radius / n))))
    return [ring[i % n] for i in range(1, k + 1)]


def vicon_twin(label: str, pace: float, stride_hz: float, distance: float):
    """Loops in room S5 of the corridor plan at the class's pace and stride frequency,
    with the VICON trials' mount, ``distance`` [m] long (the class's median path: error
    per distance depends on how far a trial goes)."""
    gait = TWIN_GAIT[label]
    # a person walks a 2.6 m circle at full pace: its curvature costs no time
    over = {"speed": round(pace, 3), "stride": round(pace / stride_hz, 3), "free_turn_deg": 60}
    return load_scenario_text(f"""
name: vicon_twin_{label}
building: corridor
gaits: {{{gait}: {json.dumps(over)}}}
agents:
  - id: ff1
    start: {{position: [30.3, 3.45], floor: 0, heading_deg: 90, time_s: {STILL_START_S}}}
    person: {{stride_scale: 1.0, speed_scale: 1.0}}
    sensors:
      imu: {{grade: microstrain_3dm_gx5_25, rate_hz: 200, axes: FRD, mount_deg: [0, 17, 0],
            mount: {json.dumps(VICON_MOUNT)}}}
    plan:
      - walk: {{via: {json.dumps(loop_via(distance))}, gait: {gait}}}
""")


def sim_vicon_like(sc, seed: int) -> Figures:
    r = simulate(sc, seed)
    rec, tr = r.imu["ff1"], r.truth["ff1"]
    pos = imu_kinematics(tr.foot, tr.mount).position
    f = vicon_like(f"seed {seed}", rec.time, rec.accel, rec.gyro, pos)
    imu = np.hstack([rec.accel, rec.gyro])

    def steps(res):
        idx = zupt_steps(res, pos)
        return idx, pos[idx, :2]
    f.drift_still = score_steps(rec.time, imu, steps, STILL_START_S)[0]
    return f


def sim_walk(sc, seed: int) -> Figures:
    """The indoor-walk twin, scored at its footfalls like the survey."""
    r = simulate(sc, seed)
    rec, st = r.imu["ff1"], r.truth["ff1"].strides
    t_mid = 0.5 * (st.t1[:-1] + st.t0[1:])
    foot = st.p1[:-1, :2]
    keep = np.concatenate([[True], np.linalg.norm(np.diff(foot, axis=0), axis=1) > 0.2])
    idx = np.searchsorted(rec.time, t_mid[keep])
    steps = lambda res: (idx, foot[keep])  # noqa: E731
    imu = np.hstack([rec.accel, rec.gyro])
    drift, pct = score_steps(rec.time, imu, steps, None)
    drift_still = score_steps(rec.time, imu, steps, sc.model.agents[0].start.time_s)[0]
    return Figures(f"seed {seed}", "walk_indoor", drift=drift, drift_still=drift_still, pct=pct,
                   vibration=rms_vibration(rec.accel),
                   stance=stance_statistics(rec.time, rec.accel, rec.gyro).summary())


def long_crawl(seeds: list[int]) -> tuple[float, float]:
    """(INS distance / true distance, true distance [m]) of ``search_flat_right`` crawled."""
    sc = load_scenario("search_flat_right")
    text = Path(sc.file).read_text().replace("gait: search", "gait: crawl")
    sc = load_scenario_text(text, file=sc.file, base_dir=sc.base_dir)
    ratios, dists = [], []
    for seed in seeds:
        r = simulate(sc, seed)
        rec, tr = r.imu["ff1"], r.truth["ff1"]
        res, pos = run(ins_params(None), rec.time, np.hstack([rec.accel, rec.gyro]))
        truth = imu_kinematics(tr.foot, tr.mount).position
        idx = zupt_steps(res, truth)
        ratios.append(path_length(pos[idx]) / path_length(truth[idx]))
        dists.append(path_length(truth[idx]))
    return float(np.mean(ratios)), float(np.mean(dists))


# -- tables ---------------------------------------------------------------------------

def mean_of(rows: list[Figures], key: str) -> float:
    v = np.array([getattr(r, key) for r in rows], float)
    v = v[np.isfinite(v)]
    return float(v.mean()) if len(v) else float("nan")


def median_stance(rows: list[Figures], key: str) -> float:
    v = np.array([r.stance.get(key, np.nan) for r in rows], float)
    v = v[np.isfinite(v)]
    return float(np.median(v)) if len(v) else float("nan")


@dataclass
class Row:
    recordings: str
    n: int
    figure: str
    real: float
    sim: float
    judged: bool = True

    @property
    def ratio(self) -> float:
        return self.sim / self.real if self.real else float("nan")

    @property
    def ok(self) -> bool:
        return bool(np.isfinite(self.ratio) and abs(self.ratio - 1.0) <= TOLERANCE)


def fmt(v: float) -> str:
    if not np.isfinite(v):
        return "-"
    return f"{v:.3f}" if abs(v) < 1 else f"{v:.2f}"


def markdown(rows: list[Row], seeds: list[int]) -> str:
    head = (f"| recordings | n | figure | real | simulated (seeds {seeds[0]}-{seeds[-1]}) | "
            "sim / real | within 25 % |\n|---|---|---|---|---|---|---|\n")
    body = "".join(
        f"| {r.recordings} | {r.n} | {r.figure} | {fmt(r.real)} | {fmt(r.sim)} | "
        f"{r.ratio:.2f} | {('yes' if r.ok else '**no**') if r.judged else '(shown)'} |\n"
        for r in rows)
    return head + body


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="1000-1019", help="A-B or a,b,c (default: the report "
                    "seeds 1000-1019; tune on 100-139)")
    ap.add_argument("--markdown", type=Path, help="also write the tables to this file")
    ap.add_argument("--json", type=Path, help="write every figure to this file")
    args = ap.parse_args()
    root = data_dir()
    if not root.is_dir():
        sys.exit(f"datasets not found at {root} (set FIRENAV_SHARED_DATA)")
    seeds = parse_seeds(args.seeds)
    t0 = time.perf_counter()
    walks = real_walks(root)
    vicon = real_vicon(root)
    print("VICON trials by class (classify_recording):")
    for label in CLASSES + ["in_place"]:
        names = [f.name for f in vicon if f.label == label]
        print(f"  {label:12s} {len(names):2d}: {', '.join(names)}")
    by_class = {c: [f for f in vicon if f.label == c] for c in CLASSES}
    twins = {c: vicon_twin(c, float(np.median([f.pace for f in by_class[c]])),
                           float(np.median([f.stride_hz for f in by_class[c]])),
                           float(np.nanmedian([f.distance for f in by_class[c]])))
             for c in CLASSES}
    sim = {c: [sim_vicon_like(twins[c], s) for s in seeds] for c in CLASSES}
    walk_twin = load_scenario("indoor_walk")
    sim_walks = [sim_walk(walk_twin, s) for s in seeds]
    crawl_ratio, crawl_m = long_crawl(seeds[:5])

    rows: list[Row] = []
    still_walks = [w for w in walks if np.isfinite(w.drift_still)]
    rows += [Row("indoor walks", len(walks), "heading drift [deg/s], INS defaults",
                 mean_of(walks, "drift"), mean_of(sim_walks, "drift")),
             Row("indoor walks", len(still_walks), "heading drift [deg/s], still-start "
                 "gyro calibration", mean_of(still_walks, "drift_still"),
                 mean_of(sim_walks, "drift_still")),
             Row("indoor walks", len(walks), "error per distance [%]", mean_of(walks, "pct"),
                 mean_of(sim_walks, "pct"))]
    walking = [f for c in ("walk_slow", "walk_normal", "walk_brisk") for f in by_class[c]]
    sim_walking = [f for c in ("walk_slow", "walk_normal", "walk_brisk") for f in sim[c]]
    for name, real, simulated in (("VICON walks", walking, sim_walking),
                                  ("VICON runs", by_class["run"], sim["run"])):
        rows += [Row(name, len(real), "heading drift [deg/s], INS defaults",
                     mean_of(real, "drift"), mean_of(simulated, "drift")),
                 Row(name, len(real), "error per distance [%]", mean_of(real, "pct"),
                     mean_of(simulated, "pct"))]
    rows.append(Row("indoor walks", len(walks), "vibration above 10 Hz [g rms]",
                    mean_of(walks, "vibration"), mean_of(sim_walks, "vibration"), judged=False))
    for c in CLASSES:
        rows.append(Row(f"VICON {c.replace('_', ' ')}", len(by_class[c]),
                        "vibration above 10 Hz [g rms]", mean_of(by_class[c], "vibration"),
                        mean_of(sim[c], "vibration"), judged=False))
    rows.append(Row("indoor walks (normal pace)", 5, "time below 20 deg/s per stride [s]",
                    median_stance([w for w in walks if w.name in ("walk_31", "walk_32",
                                   "walk_33", "walk_36", "walk_37")], "below_20_s"),
                    median_stance(sim_walks, "below_20_s")))
    for c in CLASSES:
        real = by_class[c]
        run_like = c == "run"
        for key, what in (("below_20_s", "time below 20 deg/s per stride [s]"),
                          ("below_50_s", "time below 50 deg/s per stride [s]"),
                          ("floor_dps", "lowest rate of a stance [deg/s]")):
            rows.append(Row(f"VICON {c.replace('_', ' ')}", len(real), what,
                            median_stance(real, key), median_stance(sim[c], key),
                            judged=not (run_like and key == "below_20_s")))
    rows += [Row("VICON crawls", len(by_class["crawl"]), "INS distance / true distance",
                 mean_of(by_class["crawl"], "ratio"), mean_of(sim["crawl"], "ratio")),
             Row("VICON crawls", len(by_class["crawl"]), "error per distance [%]",
                 mean_of(by_class["crawl"], "pct"), mean_of(sim["crawl"], "pct"))]
    table = markdown(rows, seeds)
    print()
    print(table)
    print(f"A {crawl_m:.0f} m simulated crawl (search_flat_right crawled, seeds {seeds[0]}-"
          f"{seeds[min(4, len(seeds) - 1)]}): the INS measures {100 * crawl_ratio:.0f} % of it.")
    print(f"Twins: pace [m/s] / stride [Hz] per class: " + ", ".join(
        f"{c} {np.median([f.pace for f in by_class[c]]):.2f}/"
        f"{np.median([f.stride_hz for f in by_class[c]]):.2f}" for c in CLASSES))
    judged = [r for r in rows if r.judged]
    print(f"\n{sum(r.ok for r in judged)} of {len(judged)} judged figures within 25 % "
          f"({time.perf_counter() - t0:.0f} s)")
    if args.markdown:
        args.markdown.write_text(table)
    if args.json:
        args.json.write_text(json.dumps({"seeds": seeds, "rows": [r.__dict__ | {"ok": r.ok}
                                                                  for r in rows],
                                         "long_crawl_ratio": crawl_ratio}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
