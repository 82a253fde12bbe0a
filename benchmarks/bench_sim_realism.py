"""Is the simulated foot IMU as hard for a ZUPT INS as real data? Real vs simulated, side by side.

    .venv/bin/python benchmarks/bench_sim_realism.py            # everything (about a minute)
    .venv/bin/python benchmarks/bench_sim_realism.py --seeds 12

Three parts, each printing the real recordings of ``../shared/data`` beside the
simulator (``indoor_walk``, the twin of the indoor walks, and gaits at other paces),
with the new foot physics (``realistic``) and without it (``ideal``: flat landings, an
IMU rigid on the foot):

1. signals around ground contact (``firenav_framework.simulator.signal_stats``): the
   lowest angular rate of a stance, how long per cycle it stays below 20/50/100 deg/s,
   heel strike to that minimum, the ringing after heel strike, the impact, standing
   sway; real values per recording, VICON trials grouped by pace;
2. how far the IMU moves while its rate is below 20 deg/s (VICON tracks the real IMU);
3. the same ZUPT INS (``zupt_ins`` defaults) on real and simulated walks, scored the
   same way: error at the footprints after a rigid fit on the first 5 strides (% of
   distance), heading drift [deg/s] and stride length against the truth [%]. For the
   twin: with the real unit's gyro bias (the scenario's default) and with the grade's
   datasheet bias only.

The simulator's physical parameters were chosen from parts 1 and 2 and from gait
literature (docs/scenarios.md); part 3 is the check, not the target.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from bench_ins_real_data import N_ALIGN, data_dir, run  # noqa: E402
from firenav_framework.simulator import load_scenario, simulate  # noqa: E402
from firenav_framework.simulator.mount import imu_kinematics  # noqa: E402
from firenav_framework.simulator.scenario import load_scenario_text  # noqa: E402
from firenav_framework.simulator.signal_stats import (quiet_displacement,  # noqa: E402
                                                      stance_statistics, true_runs)
from firenav_framework.sources.readers.foot_imu_datasets import (  # noqa: E402
    load_indoor_walk, load_vicon_trial)
from firenav_plugins.estimators.zupt_ins import ZuptInsParams, eskf  # noqa: E402
from firenav_plugins.estimators.zupt_ins.metrics import stride_errors  # noqa: E402

KEYS = ["cycle_s", "floor_dps", "below_20_s", "below_50_s", "below_100_s", "strike_to_min_s",
        "ring_acc", "ring_gyro", "impact_g", "stand_dps"]
HEAD = ["cycle", "floor", "<20", "<50", "<100", "HS-min", "ringA", "ringG", "impact", "stand"]
PACES = [("VICON slow (< 0.7 m/s)", 0.0, 0.7), ("VICON normal (0.7-1.4 m/s)", 0.7, 1.4),
         ("VICON fast (> 1.4 m/s)", 1.4, 9.0)]
NORMAL_WALKS = ("walk_31", "walk_32", "walk_33", "walk_36", "walk_37")


def row(name: str, s: dict) -> None:
    print(f"  {name:34s}" + " ".join(f"{s[k]:7.3g}" for k in KEYS))


def header(title: str) -> None:
    print(f"\n{title}\n  {'':34s}" + " ".join(f"{h:>7s}" for h in HEAD))


def variant(name: str, *, foot_model: str = "realistic", datasheet_bias: bool = False,
            gait: str | None = None):
    """The twin scenario, or a variant of it (ideal foot, datasheet gyro bias, another gait)."""
    sc = load_scenario(name)
    text = Path(sc.file).read_text().replace("building: corridor",
                                             f"building: corridor\nfoot_model: {foot_model}")
    if datasheet_bias:
        text = text.replace("gyro: {turn_on_bias_dps: 0.2}, ", "")
    if gait:
        text = text.replace("      - walk: {", f"      - walk: {{gait: {gait}, ")
    return load_scenario_text(text, file=sc.file, base_dir=sc.base_dir)


def signals(root: Path, seeds: list[int]) -> None:
    print("1. Signals around ground contact (medians per recording; rates deg/s, times s, "
          "ringing m/s^2 / deg/s rms > 10 Hz 25-150 ms after heel strike, impact g)")
    header("Real indoor walks (MicroStrain 3DM-GX5, 200 Hz; 34, 35, 38 walked fast)")
    for p in sorted((root / "indoor-walks").glob("*.mat")):
        w = load_indoor_walk(p)
        row(p.stem, stance_statistics(w.ts, w.accel, w.gyro).summary())
    header("Real VICON trials (PyShoe), medians over the trials of each pace")
    groups: dict[str, list[dict]] = {g[0]: [] for g in PACES}
    for p in sorted((root / "pyshoe-vicon").glob("*.mat")):
        v = load_vicon_trial(p)
        st = stance_statistics(v.ts, v.accel, v.gyro)
        if st.cycles < 5:
            continue
        speed = _walking_speed(v.ts, v.gt)
        for g, lo, hi in PACES:
            if lo <= speed < hi:
                groups[g].append(st.summary())
    for g, rows in groups.items():
        if rows:
            row(f"{g} n={len(rows)}", {k: float(np.nanmedian([r[k] for r in rows])) for k in KEYS})
    header(f"Simulated (seeds {seeds[0]}-{seeds[-1]}, mean of the medians)")
    for label, sc in [("indoor_walk, realistic", variant("indoor_walk")),
                      ("indoor_walk, ideal", variant("indoor_walk", foot_model="ideal")),
                      ("  gait brisk (1.6 m/s)", variant("indoor_walk", gait="brisk")),
                      ("  gait search (0.5 m/s)", variant("indoor_walk", gait="search")),
                      ("  gait slow (0.5 m/s)", variant("indoor_walk", gait="slow"))]:
        rows = []
        for seed in seeds:
            rec = simulate(sc, seed).imu["ff1"]
            rows.append(stance_statistics(rec.time, rec.accel, rec.gyro).summary())
        row(label, {k: float(np.nanmean([r[k] for r in rows])) for k in KEYS})


def _walking_speed(t: np.ndarray, pos: np.ndarray) -> float:
    """Median horizontal speed over 1-s steps, among the steps that move (> 0.2 m/s)."""
    step = int(round(1.0 / np.median(np.diff(t))))
    v = np.linalg.norm(pos[step::step, :2] - pos[:-step:step, :2], axis=1)
    v = v[v > 0.2]
    return float(np.median(v)) if len(v) else 0.0


def motion_while_quiet(root: Path, seeds: list[int]) -> None:
    print("\n2. Horizontal IMU displacement while its rate is below 20 deg/s "
          "(median per quiet interval, mm)")
    real = []
    for p in sorted((root / "pyshoe-vicon").glob("*.mat")):
        v = load_vicon_trial(p)
        if 0.7 <= _walking_speed(v.ts, v.gt) < 1.4:
            real.append(np.median(quiet_displacement(v.ts, v.gyro, v.gt)))
    print(f"  VICON normal pace: {1000 * np.median(real):.1f} mm (trials "
          f"{1000 * np.min(real):.1f}-{1000 * np.max(real):.1f}, n={len(real)})")
    for label, sc in [("realistic", variant("indoor_walk")),
                      ("ideal", variant("indoor_walk", foot_model="ideal"))]:
        vals = []
        for seed in seeds:
            r = simulate(sc, seed)
            tr = r.truth["ff1"]
            vals.append(np.median(quiet_displacement(
                r.imu["ff1"].time, r.imu["ff1"].gyro, imu_kinematics(tr.foot, tr.mount).position)))
        print(f"  indoor_walk, {label:9s}: {1000 * np.mean(vals):.1f} mm (seeds "
              f"{1000 * np.min(vals):.1f}-{1000 * np.max(vals):.1f})")


def _scores(est: np.ndarray, truth: np.ndarray, t: np.ndarray) -> tuple[float, float, float]:
    """(% error after the 5-stride fit, heading drift deg/s, stride length error %)."""
    e = stride_errors(est, truth, n_align=N_ALIGN)
    de, dt_ = np.diff(est, axis=0), np.diff(truth, axis=0)
    ang = np.degrees(np.angle(np.exp(1j * (np.arctan2(de[:, 1], de[:, 0])
                                           - np.arctan2(dt_[:, 1], dt_[:, 0])))))
    drift = float(np.polyfit(t[1:], ang - np.median(ang[:N_ALIGN]), 1)[0])
    scale = 100.0 * (np.sum(np.hypot(*de.T)) / np.sum(np.hypot(*dt_.T)) - 1.0)
    return e.mean_percent, drift, scale


def ins_check(root: Path, seeds: list[int]) -> None:
    params = ZuptInsParams()
    print("\n3. The same ZUPT INS (zupt_ins defaults), error at the footprints after a rigid "
          f"fit on the first {N_ALIGN} strides")
    print(f"  {'':34s} {'% dist':>8s} {'range':>12s} {'|drift|':>8s} {'stride':>8s}")

    def line(label: str, res: list[tuple[float, float, float]]) -> None:
        a = np.array(res)
        print(f"  {label:34s} {a[:, 0].mean():7.2f}% {a[:, 0].min():5.2f}-{a[:, 0].max():4.2f}% "
              f"{np.abs(a[:, 1]).mean():7.3f}  {a[:, 2].mean():+6.2f}%")

    real = []
    for p in sorted((root / "indoor-walks").glob("*.mat")):
        w = load_indoor_walk(p)
        _, pos = run(params, w.ts, w.imu)
        real.append(_scores(pos[w.stride_index, :2], w.gcp, w.ts[w.stride_index]))
    line("real indoor walks 31-38", real)
    line("  of which normal pace", [r for p, r in zip(sorted((root / "indoor-walks").glob(
        "*.mat")), real) if p.stem in NORMAL_WALKS])
    for label, sc in [("indoor_walk, realistic", variant("indoor_walk")),
                      ("  same, datasheet gyro bias", variant("indoor_walk", datasheet_bias=True)),
                      ("indoor_walk, ideal", variant("indoor_walk", foot_model="ideal")),
                      ("  same, datasheet gyro bias", variant("indoor_walk", foot_model="ideal",
                                                              datasheet_bias=True))]:
        line(label, [_sim_scores(sc, seed, params) for seed in seeds])
    vic, sims = [], []
    for p in sorted((root / "pyshoe-vicon").glob("*.mat")):
        v = load_vicon_trial(p)
        if 0.7 <= _walking_speed(v.ts, v.gt) < 1.6:
            vic.append(_stride_length_error(params, v.ts, v.imu, v.gt))
    for seed in seeds:
        r = simulate(variant("indoor_walk"), seed)
        rec, tr = r.imu["ff1"], r.truth["ff1"]
        sims.append(_stride_length_error(params, rec.time, np.hstack([rec.accel, rec.gyro]),
                                         imu_kinematics(tr.foot, tr.mount).position))
    print(f"  INS stride length vs VICON, walking trials: median {np.median(vic):+.2f}% "
          f"(n={len(vic)}); vs the simulated IMU: {np.mean(sims):+.2f}%")


def _sim_scores(sc, seed: int, params: ZuptInsParams) -> tuple[float, float, float]:
    r = simulate(sc, seed)
    rec, st = r.imu["ff1"], r.truth["ff1"].strides
    _, pos = run(params, rec.time, np.hstack([rec.accel, rec.gyro]))
    # footprints like the survey: the foot at rest after each stride that travelled
    t_mid = 0.5 * (st.t1[:-1] + st.t0[1:])
    foot = st.p1[:-1, :2]
    keep = np.concatenate([[True], np.linalg.norm(np.diff(foot, axis=0), axis=1) > 0.2])
    idx = np.searchsorted(rec.time, t_mid[keep])
    return _scores(pos[idx, :2], foot[keep], rec.time[idx])


def _stride_length_error(params: ZuptInsParams, t, imu, truth) -> float:
    """Median INS stride length error [%] between the middles of consecutive ZUPT runs."""
    res, pos = run(params, t, imu)
    zv = res.states[:, eskf.O_ZV] > 0.5
    starts, ends = true_runs(zv)
    mid = (starts + ends) // 2
    d_ins = np.linalg.norm(np.diff(pos[mid, :2], axis=0), axis=1)
    d_true = np.linalg.norm(np.diff(truth[mid, :2], axis=0), axis=1)
    ok = (d_true > 0.5) & (d_true < 2.5)
    return float(np.median(d_ins[ok] / d_true[ok] - 1.0) * 100.0)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=8)
    args = ap.parse_args()
    root = data_dir()
    if not root.is_dir():
        sys.exit(f"datasets not found at {root} (set FIRENAV_SHARED_DATA)")
    seeds = list(range(args.seeds))
    t0 = time.perf_counter()
    signals(root, seeds)
    motion_while_quiet(root, seeds)
    ins_check(root, seeds)
    print(f"\n({time.perf_counter() - t0:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
