"""A short field-kit load run's MAVLink log replayed: the INS tracks are identical in every
replay, on the pipeline thread or on worker threads (the load benchmark's determinism)."""
from __future__ import annotations

import struct

import numpy as np

from firenav_framework.codecs.mavlink_imu import MavlinkImuCodec
from firenav_framework.messages import ImuBlock
from firenav_framework.pipeline import load_pipeline_text
from firenav_framework.runner import Runner
from firenav_framework.simulator import load_scenario, simulate

FIREFIGHTERS = 4
PIPELINE = """
name: load-replay
timeline: {{reorder_window: 0.05, late: deliver}}
sources:
  - {{id: mav, plugin: recording, path: {log}}}
sensors:
  - {{id: imu, plugin: foot_imu, input: mav.raw, axes: [x, -y, -z],
     frames: {{block_s: 0.05, agent_map: {agents}}}}}
estimators:
  - {{id: ins, plugin: zupt_ins, input: imu.imu, imu: {{sample_rate: 200}}}}
"""


def write_load_log(path, seconds: float = 12.0) -> None:
    """The load benchmark's devices: every firefighter plays the simulated walk from
    another point, one HIGHRES_IMU per sample, receive times interleaved as on a link."""
    rec = simulate(load_scenario("indoor_walk"), 0).imu["ff1"]
    data = np.hstack((rec.accel, rec.gyro))
    n = int(seconds * rec.rate_hz)
    codec = MavlinkImuCodec()
    frames = []
    for i in range(FIREFIGHTERS):
        rows = np.roll(data, -i * len(data) // FIREFIGHTERS, axis=0)[:n]
        block = ImuBlock.from_arrays(np.arange(n) / rec.rate_hz, rows[:, :3], rows[:, 3:],
                                     frame="FRD")
        for k, f in enumerate(codec.encode(block, address=f"sys{i + 1}/comp1/imu0")):
            frames.append((1_700_000_000_000_000 + k * 5000 + 37 * i, f.data))
    frames.sort()
    path.write_bytes(b"".join(struct.pack(">Q", t) + d for t, d in frames))


def tracks(log, workers: int) -> dict:
    agents = "{" + ", ".join(f'"sys{i + 1}/*": ff{i + 1}' for i in range(FIREFIGHTERS)) + "}"
    spec = load_pipeline_text(PIPELINE.format(log=log, agents=agents))
    return Runner(spec, workers=workers).run().tracks["ins.pose"]


def test_replays_of_a_load_log_give_identical_tracks_with_and_without_workers(tmp_path):
    log = tmp_path / "mav.tlog"
    write_load_log(log)
    serial, lanes, lanes_again = (tracks(log, w) for w in (0, 2, 2))
    assert sorted(serial) == [f"ff{i + 1}" for i in range(FIREFIGHTERS)]
    for agent, track in serial.items():
        assert len(track) > 5                      # strides were detected: poses to compare
        for other in (lanes, lanes_again):
            np.testing.assert_array_equal(other[agent].t, track.t)
            np.testing.assert_array_equal(other[agent].position, track.position)
            np.testing.assert_array_equal(other[agent].heading, track.heading)
