"""The real foot-IMU datasets (../shared/data): array loaders and the .mat reader."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import scipy.io

from firenav_framework.messages import GroundTruth, ImuBlock, PoseEstimate
from firenav_framework.sources.readers import ReadOptions, find_reader
from firenav_framework.sources.readers.foot_imu_datasets import (VICON_DETECTORS,
                                                                 load_indoor_walk,
                                                                 load_vicon_trial)
from firenav_framework.testing import make_component
from firenav_plugins.sensors.foot_imu import FootImuSensor

VICON = "pyshoe-vicon/2017-11-22-11-48-35.mat"
WALK = "indoor-walks/walk_34.mat"


def read_all(path: Path):
    return list(find_reader(path)(path, ReadOptions(agent="ff2")))


def test_every_file_of_both_datasets_loads_with_consistent_arrays(shared_data):
    vicon = sorted((shared_data / "pyshoe-vicon").glob("*.mat"))
    walks = sorted((shared_data / "indoor-walks").glob("*.mat"))
    assert len(vicon) == 56 and len(walks) == 8
    for path in vicon:
        trial = load_vicon_trial(path)
        n = len(trial.ts)
        assert trial.imu.shape == (n, 6) and trial.gt.shape == (n, 3), path.name
        assert np.all(np.diff(trial.ts) > 0) and np.isfinite(trial.imu).all(), path.name
        assert set(trial.zv) == set(VICON_DETECTORS) and trial.zv["shoe"].dtype == bool
        assert trial.trial_error.min() == trial.best_error
    for path in walks:
        walk = load_indoor_walk(path)
        n = len(walk.ts)
        assert walk.imu.shape == (n, 6) and walk.pyshoe.shape == (n, 2), path.name
        assert walk.gcp.shape == (len(walk.stride_index), 2)
        assert np.all(np.diff(walk.stride_index) > 0) and walk.stride_index[-1] < n


def test_vicon_trial_is_the_z_down_device_frame_in_si_units(shared_data):
    trial = load_vicon_trial(shared_data / VICON)
    still = trial.zv["vicon"][:400]
    mean = trial.accel[:400][still].mean(axis=0)
    assert np.linalg.norm(mean) == pytest.approx(9.8, abs=0.3)
    assert mean[2] < -8.5                      # z down, as the README says
    assert np.abs(trial.gyro[:400][still]).max() < 0.5   # rad/s, not deg/s
    assert trial.best_detector in VICON_DETECTORS


def test_indoor_walk_stride_index_is_zero_based(shared_data):
    path = shared_data / "indoor-walks/walk_31.mat"
    walk = load_indoor_walk(path)
    raw = scipy.io.loadmat(path)
    # walk 31's per-stride trajectory equals its dense one exactly at these indices (the
    # 1-based reading is off by 1e-4 m); later walks edited their per-stride copy
    np.testing.assert_allclose(raw["traj_wcf"][walk.stride_index],
                               raw["reconstructed_traj_wcf"], rtol=0, atol=1e-12)
    assert np.abs(raw["traj_wcf"][walk.stride_index - 1]
                  - raw["reconstructed_traj_wcf"]).max() > 1e-5
    assert walk.stride_times[0] == raw["timestamps"].ravel()[raw["strideIndex"].ravel()[0]]
    # stored y is negated: the files are mirrored relative to ENU (ENU_FROM_DATASET_XY)
    np.testing.assert_array_equal(walk.gcp, raw["GCP"] * [1.0, -1.0])


def test_vicon_reader_interleaves_imu_and_20_hz_truth_in_time_order(shared_data):
    trial = load_vicon_trial(shared_data / VICON)
    items = read_all(shared_data / VICON)
    times = [m.t for _, m in items]
    assert times == sorted(times)
    imu = [m for p, m in items if p == "imu"]
    truth = [m for p, m in items if p == "truth"]
    assert all(isinstance(m, ImuBlock) and m.frame == "device" for m in imu)
    assert np.array_equal(np.concatenate([b.time for b in imu]), trial.ts)
    assert np.array_equal(np.concatenate([b.accel for b in imu]), trial.accel)
    assert all(isinstance(m, GroundTruth) and m.agent == "ff2" for m in truth)
    idx = np.searchsorted(trial.ts, [m.t for m in truth])
    assert np.array_equal(np.array([m.position for m in truth]), trial.gt[idx])
    assert np.median(np.diff([m.t for m in truth])) == pytest.approx(0.05, abs=0.002)
    assert {p for p, _ in items} == {"imu", "truth"}


def test_indoor_walk_reader_gives_gcp_truth_and_the_stored_reference(shared_data):
    walk = load_indoor_walk(shared_data / WALK)
    items = read_all(shared_data / WALK)
    assert [m.t for _, m in items] == sorted(m.t for _, m in items)
    truth = [m for p, m in items if p == "truth"]
    ref = [m for p, m in items if p == "reference"]
    assert [m.t for m in truth] == walk.stride_times.tolist()
    np.testing.assert_array_equal([m.position[:2] for m in truth], walk.gcp)
    assert all(isinstance(m, PoseEstimate) and np.isnan(m.heading) for m in ref)
    idx = np.searchsorted(walk.ts, [m.t for m in ref])
    np.testing.assert_array_equal([m.position[:2] for m in ref], walk.pyshoe[idx])
    assert len(ref) == pytest.approx(len(walk.ts) / 10, abs=2)


@pytest.mark.parametrize("name", [VICON, WALK, "pyshoe-vicon/2018-02-22-10-10-56.mat"])
def test_the_sensor_keeps_every_real_sample_and_reads_gravity_up(shared_data, name):
    comp, rec, stats = make_component(FootImuSensor, {"axes": ["x", "-y", "-z"]})
    n = 0
    for port, msg in read_all(shared_data / name):
        if port == "imu":
            n += len(msg)
            comp.handle("rec.imu", msg)
    comp.finish()
    out = rec.on("imu")
    assert sum(len(b) for b in out) == n and not stats.counts["under_test"]
    codes = [d.code for d in rec.on("diagnostics")]
    if name.startswith("pyshoe-vicon/2018-02-22"):
        # a crawling trial: the shoe is upside down at rest, and the check says so
        assert codes == ["imu_axes_check"]
    else:
        assert codes == [] and out[0].accel[:, 2].mean() > 7.0
