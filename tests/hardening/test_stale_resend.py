"""Stale samples re-sent by a second sender are recognised, not taken for a new clock."""
from __future__ import annotations

import struct

import numpy as np
import pytest

from firenav_framework.codecs.mavlink_imu import MavlinkImuCodec
from firenav_plugins.sensors.foot_imu.clock import DeviceClock

from tests.hardening.logs import T0_US, device_blocks
from tests.hardening.pipelines import run_text
from tests.hardening.test_damaged_logs import replay


def test_interleaved_stale_samples_map_back_to_their_own_time_and_never_resync():
    clock = DeviceClock(resync=1.0)
    out = []
    for i in range(1000):
        t_dev, t_frame = 100.0 + 0.01 * i, 5.0 + 0.01 * i
        out.append(clock.to_pipeline(t_dev, t_frame))
        if i >= 300 and i % 3 == 0:            # a copy of the sample of 2.5 s ago, now
            stale = clock.to_pipeline(t_dev - 2.5, t_frame + 0.001)
            assert stale == (pytest.approx(5.0 + 0.01 * (i - 250)), False)
    assert not any(r for _, r in out)
    np.testing.assert_allclose([t for t, _ in out], 5.0 + 0.01 * np.arange(1000))


def test_a_burst_of_stale_samples_does_not_resync_either():
    clock = DeviceClock(resync=1.0)
    for i in range(500):
        clock.to_pipeline(0.01 * i, 0.01 * i)
    burst = [clock.to_pipeline(0.01 * k, 4.995 + 1e-5 * k) for k in range(100, 130)]
    assert not any(r for _, r in burst) and max(t for t, _ in burst) <= 4.99 + 1e-9
    assert clock.to_pipeline(5.0, 5.0) == (pytest.approx(5.0), False)


def test_a_reboot_is_confirmed_by_its_second_sample():
    clock = DeviceClock(resync=1.0)
    for i in range(300):
        clock.to_pipeline(0.01 * i, 10.0 + 0.01 * i)
    first = clock.to_pipeline(0.0, 13.0)                  # the clock restarts at 0
    assert first[1] is False and first[0] <= 12.99 + 1e-9  # held: dropped by the screening
    t, resynced = clock.to_pipeline(0.01, 13.01)
    assert resynced and t == pytest.approx(13.01)
    assert clock.to_pipeline(0.02, 13.02) == (pytest.approx(13.02), False)


@pytest.mark.timeout(120)
def test_a_second_sender_of_stale_frames_does_not_move_the_track(sim_folder, tmp_path):
    codec = MavlinkImuCodec()
    packets = {}
    for sysid, block in enumerate(device_blocks(sim_folder).values(), start=1):
        packets[sysid] = [(T0_US + round(f.t * 1e6), f.data)
                          for f in codec.encode(block, address=f"sys{sysid}/comp1/imu0")]
    clean = [(us, sysid, data) for sysid, pk in packets.items() for us, data in pk]
    # a second sender re-sends ff1's frame of 3 s ago after every 4th of ff1's frames
    ff1 = packets[1]
    stale = [(us + 10, 1, ff1[i - 300][1]) for i, (us, _) in enumerate(ff1)
             if i >= 300 and i % 4 == 0]
    paths = {}
    for name, records in (("clean", clean), ("stale", clean + stale)):
        paths[name] = tmp_path / f"{name}.tlog"
        paths[name].write_bytes(b"".join(struct.pack(">Q", us) + data
                                         for us, _, data in sorted(records)))
    ref = run_text(replay(paths["clean"]), tmp_path / "a")
    res = run_text(replay(paths["stale"]), tmp_path / "b")
    imu = res.stats.counts["imu"]
    assert "clock_resyncs" not in imu                     # before: 850 re-syncs
    assert imu["duplicate_samples"] + imu.get("time_backwards_samples", 0) == len(stale)
    for agent in ("ff1", "ff2"):                          # before: the track moved by 6 m
        a, b = ref.tracks["ins.pose"][agent], res.tracks["ins.pose"][agent]
        np.testing.assert_array_equal(a.t, b.t)
        np.testing.assert_allclose(a.position, b.position, atol=1e-9)
