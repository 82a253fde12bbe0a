"""Regression tests of the gaits the foot INS got wrong: crawling (simulated and real),
running at 3 m/s with a saturating accelerometer, and the height drift on level floors."""
from __future__ import annotations

import numpy as np
import pytest

from firenav_framework.simulator import simulate
from firenav_plugins.estimators.zupt_ins import ZuptInsParams, detectors, eskf
from firenav_plugins.estimators.zupt_ins.metrics import path_length, pyshoe_armse
from firenav_plugins.estimators.zupt_ins.retro import correct_positions

from .conftest import FLU, REPO, run_engine

SCENARIOS = REPO / "benchmarks" / "scenarios"
TO_FLU = {"FRD": FLU, "FLU": np.ones(3)}


def simulated_steps(name: str, seed: int):
    """(step positions of the INS, true foot positions at those instants, true strides)."""
    r = simulate(SCENARIOS / f"{name}.yaml", seed)
    rec, truth = r.imu["ff1"], r.truth["ff1"]
    axes = TO_FLU[rec.frame]
    res = run_engine(rec.time, rec.accel * axes, rec.gyro * axes)
    steps = res.events[res.events[:, eskf.E_KIND] == eskf.EVENT_STEP]
    at = np.minimum(np.searchsorted(rec.time, steps[:, eskf.E_T]), len(rec.time) - 1)
    return res, steps[:, eskf.E_POS:eskf.E_POS + 3], truth.foot.position[at], len(truth.strides.t0)


@pytest.mark.parametrize("seed", [7, 8])
def test_a_simulated_crawl_measures_the_distance_crawled(seed):
    """With the upright detector levels the crawling foot's slow swings passed for
    stances: 34 m of crawl measured as 5-7 m (issue: 35.6 m of 108 m)."""
    res, est, truth, _ = simulated_steps("ins_crawl", seed)
    assert (res.stat[:, 2] == detectors.MODE_CRAWL).mean() > 0.5
    assert path_length(est) == pytest.approx(path_length(truth), rel=0.08)


@pytest.mark.parametrize("seed", [7, 8])
def test_running_at_3_m_s_with_a_saturating_accelerometer_is_tracked(seed):
    """The simulator's running gait has no quiet moment in a stance: its statistic's floor
    reaches 10^8.5, where the upright ceiling of 10^8.7 left the threshold under most
    stances (seed 8: 6 of 30 strides found, 30 % too long)."""
    r = simulate(SCENARIOS / "ins_run.yaml", seed)
    assert r.imu["ff1"].saturated.mean() > 0.02          # the +-8 g range is exceeded
    res, est, truth, strides = simulated_steps("ins_run", seed)
    # a missed stance joins two strides into one step: with the brief stances of seed 8
    # a third of the strides are found, yet the distance is right
    assert len(est) >= 0.3 * strides
    assert path_length(est) == pytest.approx(path_length(truth), rel=0.08)


def test_a_real_crawl_is_tracked_with_the_crawl_levels(vicon_crawl_tuning):
    """The even-numbered (tuning) VICON crawl that the upright levels lost (ARMSE 0.19 m;
    0.10 m with the crawl levels)."""
    tr = vicon_crawl_tuning
    res = run_engine(tr.ts, tr.accel * FLU, tr.gyro * FLU)
    pos = correct_positions(res.states[:, eskf.O_T], res.states[:, eskf.O_POS:eskf.O_POS + 3],
                            res.events)
    assert pyshoe_armse(pos[:, :2], tr.gt) < 0.12


def test_level_floors_keep_their_height_on_a_jog(shared_data):
    """walk_35 jogs: its strides rose 0.5-1 m each in the INS; the floor is level, so the
    height at the strides must come back to it (before: 0.65 m at the end)."""
    from firenav_framework.sources.readers.foot_imu_datasets import load_indoor_walk

    w = load_indoor_walk(shared_data / "indoor-walks" / "walk_35.mat")
    res = run_engine(w.ts, w.accel * FLU, w.gyro * FLU)
    z = res.states[w.stride_index, eskf.O_POS + 2]
    z = np.abs(z - z[0])
    assert z[-1] < 0.1 and np.median(z) < 0.1
    # the horizontal track is the one without the level floors
    flat = run_engine(w.ts, w.accel * FLU, w.gyro * FLU, ZuptInsParams(height={"correction": False}))
    np.testing.assert_array_equal(res.states[:, eskf.O_POS:eskf.O_POS + 2],
                                  flat.states[:, eskf.O_POS:eskf.O_POS + 2])
