"""The simulated foot IMU behaves around ground contact like the real ones in ../shared/data.

Real side: the indoor walks at normal pace (31-33, 36, 37: the recordings the
``indoor_walk`` scenario is the twin of) and three VICON trials walked at a similar
pace; simulated side: ``indoor_walk``. The figures are those of
:mod:`firenav_framework.simulator.signal_stats`; ``benchmarks/bench_sim_realism.py``
prints them all side by side.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from firenav_framework.simulator import load_scenario, simulate
from firenav_framework.simulator.mount import imu_kinematics
from firenav_framework.simulator.scenario import load_scenario_text
from firenav_framework.simulator.signal_stats import quiet_displacement, stance_statistics
from firenav_framework.sources.readers.foot_imu_datasets import (load_indoor_walk,
                                                                 load_vicon_trial)

WALKS = ("walk_31", "walk_32", "walk_33", "walk_36", "walk_37")
VICON = ("2017-11-22-11-38-45", "2017-11-22-11-40-44", "2017-11-22-11-26-05")
#: figure -> how far outside the range of the real recordings the simulation may be
#: (factor on the lowest and the highest value)
FIGURES = {"floor_dps": 1.2, "below_20_s": 1.25, "below_50_s": 1.1, "below_100_s": 1.1,
           "strike_to_min_s": 1.15, "ring_acc": 1.2, "ring_gyro": 1.2, "impact_g": 1.2}


@pytest.fixture(scope="module")
def simulated():
    return [simulate("indoor_walk", seed) for seed in (0, 1)]


def test_stance_signals_are_in_the_range_of_the_real_walks(shared_data, simulated):
    real = [stance_statistics(w.ts, w.accel, w.gyro).summary() for w in
            (load_indoor_walk(shared_data / "indoor-walks" / f"{n}.mat") for n in WALKS)]
    runs = [stance_statistics(r.imu["ff1"].time, r.imu["ff1"].accel, r.imu["ff1"].gyro)
            for r in simulated]
    assert all(st.cycles > 40 for st in runs)
    sim = {k: np.mean([st.summary()[k] for st in runs]) for k in FIGURES}  # two people
    for key, slack in FIGURES.items():
        lo, hi = min(x[key] for x in real), max(x[key] for x in real)
        assert lo / slack <= sim[key] <= hi * slack, (key, sim[key], lo, hi)
    # the test tells: the ideal foot (flat landings, IMU rigid on it) is far outside
    sc = load_scenario("indoor_walk")
    text = Path(sc.file).read_text().replace("building: corridor",
                                             "building: corridor\nfoot_model: ideal")
    rec = simulate(load_scenario_text(text, base_dir=sc.base_dir), 0).imu["ff1"]
    ideal = stance_statistics(rec.time, rec.accel, rec.gyro).summary()
    assert ideal["floor_dps"] < 0.2 * min(x["floor_dps"] for x in real)
    assert ideal["ring_gyro"] < 0.2 * min(x["ring_gyro"] for x in real)


def test_the_imu_moves_as_much_while_its_rate_is_low_as_on_real_feet(shared_data, simulated):
    """VICON tracks the real IMU: how far it travels while turning at under 20 deg/s is
    what zero-velocity updates there lose."""
    real = np.concatenate([quiet_displacement(v.ts, v.gyro, v.gt) for v in
                           (load_vicon_trial(shared_data / "pyshoe-vicon" / f"{n}.mat")
                            for n in VICON)])
    for r in simulated:
        tr = r.truth["ff1"]
        sim = quiet_displacement(r.imu["ff1"].time, r.imu["ff1"].gyro,
                                 imu_kinematics(tr.foot, tr.mount).position)
        assert 0.7 < np.median(sim) / np.median(real) < 1.4, (np.median(sim), np.median(real))


# -- the INS on real and simulated recordings (benchmarks/bench_sim_realism.py: all) -----

FLU = np.array([1.0, -1.0, -1.0])      # the z-down MicroStrain and its twins -> FLU


def _ins(t, accel, gyro, still_s: float | None = None):
    """The ZUPT INS with its defaults (or the gyro bias from ``still_s`` of rest):
    (positions (N, 3), zero-velocity flags (N,))."""
    from firenav_plugins.estimators.zupt_ins import BlockResult, InsEngine, ZuptInsParams, eskf
    p = ZuptInsParams() if still_s is None else ZuptInsParams(
        alignment={"gyro_bias": True, "duration": still_s - 0.3})
    eng = InsEngine(p.detector_config(200.0), p.filter_config(200.0))
    res = BlockResult.concat([eng.process(t, accel * FLU, gyro * FLU), eng.finish()])
    return res.states[:, eskf.O_POS:eskf.O_POS + 3], res.states[:, eskf.O_ZV] > 0.5


def _steps(zv: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """Middles of the zero-velocity runs, one per 0.15 m the truth moved."""
    from firenav_framework.simulator.signal_stats import true_runs
    a, b = true_runs(zv)
    keep, last = [], None
    for i in (a + b) // 2:
        if last is None or np.linalg.norm(truth[i, :2] - truth[last, :2]) >= 0.15:
            keep.append(i)
            last = i
    return np.array(keep)


def test_the_vicon_trials_sort_themselves_into_walks_runs_crawls_and_motion_in_place(
        shared_data):
    from firenav_framework.simulator.recordings import classify_recording
    labels = {}
    for p in sorted((shared_data / "pyshoe-vicon").glob("*.mat")):
        v = load_vicon_trial(p)
        c = classify_recording(v.ts, v.accel, v.gyro, v.gt, np.array([0.0, 0.0, -1.0]))
        labels.setdefault(c.label, []).append(p.stem)
    counts = {k: len(v) for k, v in labels.items()}
    assert counts == {"walk_slow": 7, "walk_normal": 14, "walk_brisk": 8, "run": 19,
                      "crawl": 4, "in_place": 4}
    assert all(n.startswith("2018-02-22") for n in labels["crawl"])      # one session
    assert all(n.startswith(("2017-11-27", "2017-12-15")) for n in labels["run"])
    assert all(n.startswith("2018-02-09") for n in labels["in_place"])


def test_the_twin_of_the_indoor_walks_drifts_in_heading_like_them(shared_data):
    """The issue's figure: 0.157 deg/s on the real walks against 0.016 with the old
    datasheet errors. Sixteen seeds: within 35 % (benchmarks/bench_sim_realism.py, the
    twenty report seeds: see docs/scenarios.md)."""
    from firenav_framework.simulator.recordings import heading_drift
    real = []
    for p in sorted((shared_data / "indoor-walks").glob("*.mat")):
        w = load_indoor_walk(p)
        pos, _ = _ins(w.ts, w.accel, w.gyro)
        real.append(abs(heading_drift(pos[w.stride_index, :2], w.gcp,
                                      w.ts[w.stride_index]).drift_dps))

    def twin(errors: str, seeds) -> float:
        out = []
        for seed in seeds:
            r = simulate("indoor_walk", seed, imu_errors=errors)
            rec, st = r.imu["ff1"], r.truth["ff1"].strides
            pos, _ = _ins(rec.time, rec.accel, rec.gyro)
            idx = np.searchsorted(rec.time, 0.5 * (st.t1[:-1] + st.t0[1:]))
            out.append(abs(heading_drift(pos[idx, :2], st.p1[:-1, :2], rec.time[idx]).drift_dps))
        return float(np.mean(out))
    worn, datasheet = twin("as_worn", range(1000, 1016)), twin("datasheet", range(1000, 1004))
    assert np.mean(real) == pytest.approx(0.157, abs=0.002)
    assert abs(worn / np.mean(real) - 1) < 0.35, (worn, np.mean(real))
    assert datasheet < 0.4 * worn


def test_crawling_the_ins_measures_the_distance_on_real_and_simulated_crawls(shared_data):
    """The real crawl trials: the INS measures their length (so the old simulator's crawl,
    35.6 m of 108 m, was the simulator's fault); the simulated crawl now does the same."""
    real = []
    for p in sorted((shared_data / "pyshoe-vicon").glob("2018-02-22-*.mat")):
        v = load_vicon_trial(p)
        pos, zv = _ins(v.ts, v.accel, v.gyro)
        idx = _steps(zv, v.gt)
        real.append(np.sum(np.linalg.norm(np.diff(pos[idx, :2], axis=0), axis=1))
                    / np.sum(np.linalg.norm(np.diff(v.gt[idx, :2], axis=0), axis=1)))
    assert all(0.8 < x < 1.2 for x in real), real
    r = simulate("field_crawl_search", 1000)
    rec, tr = r.imu["ff1"], r.truth["ff1"]
    truth = imu_kinematics(tr.foot, tr.mount).position
    pos, zv = _ins(rec.time, rec.accel, rec.gyro)
    idx = _steps(zv, truth)
    crawled = np.sum(np.linalg.norm(np.diff(truth[idx, :2], axis=0), axis=1))
    assert crawled > 80
    ratio = np.sum(np.linalg.norm(np.diff(pos[idx, :2], axis=0), axis=1)) / crawled
    assert 0.8 < ratio < 1.2, ratio


@pytest.mark.parametrize("label, gait, key", [
    ("walk_slow", "slow", "below_20_s"), ("walk_normal", "walk", "below_20_s"),
    ("walk_brisk", "brisk", "below_20_s"), ("run", "run", "below_50_s"),
    ("crawl", "crawl", "below_20_s")])
def test_stance_quiet_time_per_gait_is_the_real_one(shared_data, label, gait, key):
    """Time per stride the rate stays low: the VICON trials of a class against that gait
    at the class's pace and cadence, on the VICON trials' mount (two seeds: within 30 %;
    the benchmark's twenty: 25 %). Running is judged below 50 deg/s: below 20 it is
    quiet for 0-40 ms a stride, a sample or two."""
    from firenav_framework.simulator.recordings import classify_recording
    real, paces, rates = [], [], []
    for p in sorted((shared_data / "pyshoe-vicon").glob("*.mat")):
        v = load_vicon_trial(p)
        c = classify_recording(v.ts, v.accel, v.gyro, v.gt, np.array([0.0, 0.0, -1.0]))
        if c.label == label:
            real.append(stance_statistics(v.ts, v.accel, v.gyro).summary()[key])
            paces.append(c.speed_mps)
            rates.append(c.stride_hz)
    pace, hz = float(np.median(paces)), float(np.median(rates))
    ring = [[round(float(29.0 + 1.3 * np.cos(a)), 3), round(float(3.45 + 1.3 * np.sin(a)), 3)]
            for a in np.linspace(0, 2 * np.pi, 36, endpoint=False)]
    text = f"""
building: corridor
gaits: {{{gait}: {{speed: {pace:.3f}, stride: {pace / hz:.3f}, free_turn_deg: 60}}}}
agents:
  - id: a
    start: {{position: [30.3, 3.45], floor: 0, heading_deg: 90, time_s: 3}}
    person: {{stride_scale: 1.0, speed_scale: 1.0}}
    sensors:
      imu: {{grade: microstrain_3dm_gx5_25, rate_hz: 200, axes: FRD, mount_deg: [0, 17, 0],
            mount: {{flex_deg: 7, damping: 0.3}}}}
    plan:
      - walk: {{via: {(ring * 4)[1:] + ring[:1]}, gait: {gait}}}
"""
    sims = [simulate(load_scenario_text(text), s).imu["a"] for s in (1000, 1001)]
    sim = np.median([stance_statistics(r.time, r.accel, r.gyro).summary()[key] for r in sims])
    assert abs(sim / np.nanmedian(real) - 1) < 0.3, (sim, np.nanmedian(real))
