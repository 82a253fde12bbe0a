"""Throughput of the foot_imu sensor on a real recording and on CAN / MAVLink frames.

Prints samples per second of wall time for

* ImuBlock input (a real PyShoe trial, 0.1 s blocks) through the full sensor, beside a
  bare baseline that only rotates the axes (the least any conditioning must do);
* CAN frames (3 per sample) and MAVLink HIGHRES_IMU packets through the sensor, beside
  cantools / pymavlink decoding alone.

Run: ``python benchmarks/bench_foot_imu.py [--repeat N]`` (uses ../shared/data when
present, else a synthetic 60 s walk). Figures are noisy on a shared machine: compare
the columns of one run, not runs.
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from firenav_framework.codecs import get_codec, to_raw_frames
from firenav_framework.messages import ImuBlock
from firenav_framework.sources.readers import ReadOptions, find_reader
from firenav_framework.testing import make_component
from firenav_plugins.sensors.foot_imu import FootImuSensor

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
TRIAL = DATA / "pyshoe-vicon" / "2018-02-09-11-22-01.mat"
FRD = ["x", "-y", "-z"]


def blocks() -> list[ImuBlock]:
    if TRIAL.is_file():
        return [m for p, m in find_reader(TRIAL)(TRIAL, ReadOptions()) if p == "imu"]
    rng = np.random.default_rng(0)
    n = 12000
    t = np.arange(n) * 0.005
    a = np.array([0, 0, -9.81]) + rng.normal(0, 2, (n, 3))
    g = rng.normal(0, 1, (n, 3))
    return [ImuBlock.from_arrays(t[i:i + 20], a[i:i + 20], g[i:i + 20], agent="ff1",
                                 device="ff1/imu", frame="device") for i in range(0, n, 20)]


def through_sensor(msgs) -> float:
    comp, rec, _ = make_component(FootImuSensor, {"axes": FRD})
    t0 = time.perf_counter()
    for m in msgs:
        comp.handle("in", m)
    comp.finish()
    wall = time.perf_counter() - t0
    assert rec.on("imu")
    return wall


def rotate_only(msgs) -> float:
    R = np.diag([1.0, -1.0, -1.0])
    t0 = time.perf_counter()
    for m in msgs:
        ImuBlock(t=m.t, agent=m.agent, device=m.device, time=m.time, accel=m.accel @ R.T,
                 gyro=m.gyro @ R.T, frame="FLU")
    return time.perf_counter() - t0


def decode_only_can(frames) -> float:
    db = get_codec("can_imu")().db
    t0 = time.perf_counter()
    for f in frames:
        db.decode_message(f.channel, f.data)
    return time.perf_counter() - t0


def decode_only_mavlink(frames) -> float:
    from pymavlink.dialects.v20 import common

    parser = common.MAVLink(None)
    t0 = time.perf_counter()
    for f in frames:
        parser.decode(bytearray(f.data))
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3, help="best of this many runs")
    args = ap.parse_args()
    bl = blocks()
    n = sum(len(b) for b in bl)
    t = np.concatenate([b.time for b in bl]) - bl[0].time[0]
    a = np.concatenate([b.accel for b in bl])
    g = np.concatenate([b.gyro for b in bl])
    walk = ImuBlock.from_arrays(t, a, g, frame="device")
    can = to_raw_frames(get_codec("can_imu")().encode(walk), transport="can", device="can0")
    mav = to_raw_frames(get_codec("mavlink_imu")().encode(walk), transport="mavlink",
                        device="sys1/comp1")

    def best(fn, msgs):
        return min(fn(msgs) for _ in range(args.repeat))

    print(f"{n} samples ({n / 200:.0f} s at 200 Hz) from "
          f"{TRIAL.name if TRIAL.is_file() else 'a synthetic walk'}; best of {args.repeat}")
    print(f"{'input':<24}{'foot_imu [samples/s]':>22}{'baseline [samples/s]':>22}  baseline")
    rows = [("ImuBlock (0.1 s)", best(through_sensor, bl), best(rotate_only, bl), "axes rotation only"),
            ("CAN frames (3/sample)", best(through_sensor, can), best(decode_only_can, can),
             "cantools decode only"),
            ("MAVLink HIGHRES_IMU", best(through_sensor, mav), best(decode_only_mavlink, mav),
             "pymavlink decode only")]
    for name, ours, base, what in rows:
        print(f"{name:<24}{n / ours:>22,.0f}{n / base:>22,.0f}  {what}")
    print(f"(real time needs 200 samples/s per foot: the ImuBlock path serves "
          f"{n / rows[0][1] / 200:,.0f} feet per core)")


if __name__ == "__main__":
    main()
