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
