"""The public foot-IMU formats read as published: x-io Gait-Tracking (NGIMU and x-IMU),
Constrained-ZUPT-FGO measData, gaitmap's two-sensor CSV, OpenShoe's data_inert.txt and
PyShoe's hallway trials. Every file here is written by the test, in the project's own
layout, from a synthetic walk with exact truth (tests/ins/synthetic.py)."""
from __future__ import annotations

import csv
import math

import numpy as np
import pytest

from firenav_framework.cli import main
from firenav_framework.formats.base import ReaderError, ReadOptions
from firenav_framework.formats.csv_layout import CsvColumns
from firenav_framework.sources.readers import find_reader
from firenav_plugins.estimators.zupt_ins.metrics import path_length
from tests.ins.synthetic import Stride, walk

G0 = 9.80665
STRIDES = [Stride((1.2, 0.0, 0.0)), Stride((1.2, 0.0, 0.0), turn=math.radians(30)),
           Stride((1.0, 0.6, 0.0)), Stride((1.2, 0.0, 0.0))]


def synthetic(rate: float):
    return walk(STRIDES, rate=rate, start_rest=1.5, end_rest=1.0)


def read(path, columns=None, fmt="auto"):
    opts = ReadOptions(columns=CsvColumns(**columns) if columns else None)
    return list(find_reader(path, fmt)(path, opts))


def imu_of(msgs, device=None):
    blocks = [m for p, m in msgs if p == "imu" and (device is None or m.device == device)]
    return (np.concatenate([b.time for b in blocks]), np.concatenate([b.accel for b in blocks]),
            np.concatenate([b.gyro for b in blocks]), blocks)


def _fmt(values) -> str:
    return ",".join(repr(float(v)) for v in values)


def write_xio(path, rec, *, repeat_every: int = 0):
    """Gait-Tracking's CSV: time [s], gyroscope [deg/s], accelerometer [g] (the NGIMU
    logs some rows twice, as in the project's own files)."""
    lines = ["Time (s),Gyroscope X (deg/s),Gyroscope Y (deg/s),Gyroscope Z (deg/s),"
             "Accelerometer X (g),Accelerometer Y (g),Accelerometer Z (g)"]
    for i, (t, a, w) in enumerate(zip(rec.t, rec.accel, rec.gyro)):
        row = _fmt([t, *np.degrees(w), *(a / G0)])
        lines.append(row)
        if repeat_every and i % repeat_every == 0:
            lines.append(row)
    path.write_text("\n".join(lines) + "\n")
    return path


def test_xio_gait_tracking_is_recognised_by_its_header(tmp_path):
    rec = synthetic(400.0)
    t, accel, gyro, blocks = imu_of(read(write_xio(tmp_path / "short_walk.csv", rec)))
    assert len(t) == len(rec.t) and blocks[0].frame == "device"
    np.testing.assert_allclose(accel, rec.accel, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(gyro, rec.gyro, rtol=1e-12, atol=1e-12)


def test_xio_gait_tracking_runs_through_the_foot_ins_pipeline(tmp_path, repo, capsys):
    """The worked command of docs/formats/xio-gait-tracking.md, on a z-up device: the
    repeated rows are dropped by the sensor and the step track covers the truth's path."""
    rec = synthetic(400.0)
    path = write_xio(tmp_path / "walk.csv", rec, repeat_every=97)
    out = tmp_path / "out"
    code = main(["run", str(repo / "pipelines" / "foot-ins.yaml"), "--input", str(path),
                 "--set", "sensors.imu.axes=[x, y, z]", "--output", str(out), "--quiet"])
    assert code == 0, capsys.readouterr().err
    with open(out / "ins_pose.csv") as fh:
        poses = list(csv.DictReader(fh))
    xy = np.array([[float(p["x"]), float(p["y"])] for p in poses])
    assert path_length(xy) == pytest.approx(path_length(rec.footprints), rel=0.02)
    assert "imu_axes_check" not in (out / "diagnostics.jsonl").read_text()


def test_xio_ximu_rows_are_a_256_hz_sample_clock_not_the_packet_number(tmp_path):
    rec = synthetic(256.0)
    lines = ["Packet number,Gyroscope X (deg/s),Gyroscope Y (deg/s),Gyroscope Z (deg/s),"
             "Accelerometer X (g),Accelerometer Y (g),Accelerometer Z (g),"
             "Magnetometer X (G),Magnetometer Y (G),Magnetometer Z (G)"]
    packet = 3
    for a, w in zip(rec.accel, rec.gyro):
        lines.append(f"{packet}," + _fmt([*np.degrees(w), *(a / G0), 0.2, 0.1, -0.3]))
        packet += 1 + (packet % 3 == 0)          # the packet counter skips numbers
    path = tmp_path / "straightLine_CalInertialAndMag.csv"
    path.write_text("\n".join(lines) + "\n")
    t, accel, _, blocks = imu_of(read(path))
    np.testing.assert_allclose(t, np.arange(len(rec.t)) / 256.0, atol=1e-12)
    np.testing.assert_allclose(accel, rec.accel, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(blocks[0].mag[0], [20.0, 10.0, -30.0])   # gauss -> uT


def write_fgo(folder, rec, foot="Left"):
    """measData/imuMeas<Foot>.csv (time_index at 60 Hz, SI, the project's own ZUPT flags)
    and positionGt.csv (both feet, north-east-down)."""
    folder.mkdir(exist_ok=True)
    imu = folder / f"imuMeas{foot}.csv"
    with open(imu, "w") as fh:
        fh.write("time_index,acc_x,acc_y,acc_z,gyro_x,gyro_y,gyro_z,is_zero_vel\n")
        for k, (a, w) in enumerate(zip(rec.accel, rec.gyro)):
            fh.write(f"{k},{_fmt([*a, *w])},1\n")
    # ENU (x east, y north, z up) -> the file's (x north, y east, z down)
    ned = np.column_stack([rec.position[:, 1], rec.position[:, 0], -rec.position[:, 2]])
    with open(folder / "positionGt.csv", "w") as fh:
        fh.write("time_index,pos_left_x,pos_left_y,pos_left_z,pos_right_x,pos_right_y,pos_right_z\n")
        for k, p in enumerate(ned):
            fh.write(f"{k},{_fmt(p)},{_fmt(p + [0.0, 0.3, 0.0])}\n")
    return imu


def test_zupt_fgo_measdata_with_its_truth_in_enu(tmp_path):
    rec = synthetic(60.0)
    msgs = read(write_fgo(tmp_path / "measData", rec))
    t, accel, _, _ = imu_of(msgs)
    np.testing.assert_allclose(t, np.arange(len(rec.t)) / 60.0, atol=1e-12)
    np.testing.assert_allclose(accel, rec.accel, rtol=1e-12, atol=1e-12)
    truth = [m for p, m in msgs if p == "truth"]
    assert len(truth) == len(rec.t) and {m.device for m in truth} == {"gt_left"}
    np.testing.assert_allclose([m.position for m in truth], rec.position, atol=1e-12)
    assert [m.t for _, m in msgs] == sorted(m.t for _, m in msgs)


def write_gaitmap(path, rec):
    """gaitmap's two-sensor CSV: rows 'sensor' and 'axis', the sample index, m/s^2, deg/s;
    the right foot here is the left one's data mirrored in y."""
    axes = ["acc_x", "acc_y", "acc_z", "gyr_x", "gyr_y", "gyr_z"]
    sensors = [s for _ in axes for s in ("left_sensor", "right_sensor")]
    lines = ["sensor," + ",".join(sensors), "axis," + ",".join(a for a in axes for _ in (0, 1))]
    for k, (a, w) in enumerate(zip(rec.accel, rec.gyro)):
        left = [*a, *np.degrees(w)]
        right = [left[0], -left[1], left[2], -left[3], left[4], -left[5]]
        lines.append(f"{k}," + _fmt(v for pair in zip(left, right) for v in pair))
    path.write_text("\n".join(lines) + "\n")
    return path


def test_gaitmap_reads_both_sensors_once_given_the_rate(tmp_path):
    rec = synthetic(204.8)
    path = write_gaitmap(tmp_path / "imu_sample.csv", rec)
    with pytest.raises(ReaderError, match="needs `rate`"):
        read(path)
    msgs = read(path, {"rate": 204.8})
    lt, la, lg, blocks = imu_of(msgs, "ff1/left_sensor")
    rt, ra, rg, _ = imu_of(msgs, "ff1/right_sensor")
    assert blocks[0].frame == "FLU"        # gaitmap's foot sensor frame: x toe, y left, z up
    np.testing.assert_allclose(lt, np.arange(len(rec.t)) / 204.8, atol=1e-12)
    np.testing.assert_allclose(la, rec.accel, atol=1e-12)
    np.testing.assert_allclose(lg, rec.gyro, atol=1e-12)
    np.testing.assert_allclose(ra[:, 1], -rec.accel[:, 1], atol=1e-12)
    np.testing.assert_allclose(rg[:, 2], -rec.gyro[:, 2], atol=1e-12)


def test_openshoe_data_inert_is_whitespace_with_g_and_a_time_stamp(tmp_path):
    rec = synthetic(250.0)
    header = ("Header a_x [g] a_y [g] a_z [g] ar_x [rad/s] ar_y [rad/s] ar_z [rad/s] Counter "
              "Checksum Nr Filtered ts[s] Unfiltered ts[s] Pred. ts[s] Freq. [Hz] m_x [G] "
              "m_y [G] m_z [G]")
    lines = [header]
    for k, (t, a, w) in enumerate(zip(rec.t, rec.accel, rec.gyro)):
        lines.append(f"{0xC8:x}  " + "  ".join(repr(float(v)) for v in a / G0) + "  "
                     + " ".join(repr(float(v)) for v in w)
                     + f"  {k} {0xBEEF:x}  {k}  {float(t)!r} {float(t)!r} {float(t)!r}  250.0  0.2 0.1 -0.3")
    path = tmp_path / "data_inert.txt"
    path.write_text("\r\n".join(lines) + "\r\n")
    t, accel, gyro, _ = imu_of(read(path))
    np.testing.assert_allclose(t, rec.t, atol=1e-12)
    np.testing.assert_allclose(accel, rec.accel, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(gyro, rec.gyro, rtol=1e-12, atol=1e-12)


def test_pyshoe_hallway_trial_has_truth_at_its_indices(tmp_path):
    import scipy.io

    rec = synthetic(200.0)
    idx = np.array([0, 400, 800, len(rec.t) - 1])
    gt = rec.position[idx] * [1.0, -1.0, 1.0]          # PyShoe's mirrored y
    path = tmp_path / "processed_data.mat"
    scipy.io.savemat(path, {"imu": np.hstack([rec.accel, rec.gyro]), "ts": rec.t[None, :],
                            "gt": gt, "gt_idx": idx[None, :]})
    msgs = read(path)
    truth = [m for p, m in msgs if p == "truth"]
    np.testing.assert_allclose([m.t for m in truth], rec.t[idx])
    np.testing.assert_allclose([m.position for m in truth], rec.position[idx], atol=1e-12)
    assert len(imu_of(msgs)[0]) == len(rec.t)
