"""The foot_imu sensor: axes, units, calibration, every bad-input case, frame inputs.

Expectations are independent of the code under test: analytic rotations of known
vectors, calibration applied sample by sample with explicit matrices, and bad
samples planted at known places with their exact counts.
"""
from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError

from firenav_framework.codecs import to_raw_frames
from firenav_framework.codecs.can_imu import CanImuCodec
from firenav_framework.codecs.imu_lines import ImuLinesCodec
from firenav_framework.codecs.mavlink_imu import MavlinkImuCodec
from firenav_framework.messages import IMU_FLAG_BITS, ImuBlock, RawFrame
from firenav_framework.testing import check_plugin, make_component
from firenav_framework.yaml_locations import ConfigError
from firenav_plugins.sensors.foot_imu import FootImuSensor
from firenav_plugins.sensors.foot_imu.calibration import axes_matrix
from firenav_plugins.sensors.foot_imu.clock import DeviceClock

G = 9.81
FRD = ["x", "-y", "-z"]
SAT, GAP = IMU_FLAG_BITS["saturated"], IMU_FLAG_BITS["gap_before"]


def motion(n=400, seed=1, t0=0.0, rate=200.0):
    """Distinct, plausible samples: gravity on -z (a z-down device) plus noise."""
    rng = np.random.default_rng(seed)
    t = t0 + np.arange(n) / rate
    accel = np.array([0.0, 0.0, -G]) + rng.normal(0, 0.5, (n, 3))
    gyro = rng.normal(0, 0.05, (n, 3))
    return t, accel, gyro


def blocks(t, accel, gyro, size=20, agent="ff1", device="ff1/imu", **kw):
    return [ImuBlock.from_arrays(t[i:i + size], accel[i:i + size], gyro[i:i + size],
                                 agent=agent, device=device, frame="device", **kw)
            for i in range(0, len(t), size)]


def device_block(t, accel, gyro) -> ImuBlock:
    return ImuBlock.from_arrays(t, accel, gyro, frame="device")


def encode_can_imu(t, accel, gyro, node=0):
    return CanImuCodec().encode(device_block(t, accel, gyro), address=f"node{node}")


def encode_mavlink_imu(t, accel, gyro, imu_id=0, send="HIGHRES_IMU", **options):
    return MavlinkImuCodec({"send": send, **options}).encode(
        device_block(t, accel, gyro), address=f"sys1/comp1/imu{imu_id}")


def run(params=None, messages=(), **kw):
    """Feed messages through a fresh sensor; (output blocks, diagnostics, counts).

    The samples of :func:`motion` come from a z-down device, so ``axes`` defaults to FRD.
    """
    comp, rec, stats = make_component(FootImuSensor, {"axes": FRD, **(params or {})}, **kw)
    comp.start()
    for msg in messages:
        comp.handle("in", msg)
    comp.finish()
    return rec.on("imu"), rec.on("diagnostics"), dict(stats.counts["under_test"])


def joined(out):
    return (np.concatenate([b.time for b in out]), np.concatenate([b.accel for b in out]),
            np.concatenate([b.gyro for b in out]), np.concatenate([b.flags for b in out]))


# -- axes, units, calibration ------------------------------------------------------------

def test_z_down_device_at_rest_reads_plus_g_on_flu_z():
    n = 50
    t = np.arange(n) * 0.005
    accel = np.tile([0.0, 0.0, -G], (n, 1))
    out, diags, counts = run({"axes": FRD}, blocks(t, accel, np.zeros((n, 3))))
    _, a, _, _ = joined(out)
    np.testing.assert_allclose(a, np.tile([0.0, 0.0, G], (n, 1)), atol=1e-12)
    assert all(b.frame == "FLU" for b in out) and counts == {} and diags == []


@pytest.mark.parametrize("axes, device_vec, flu_vec", [
    (["x", "-y", "-z"], (1, 2, 3), (1, -2, -3)),
    (["y", "-x", "z"], (1, 2, 3), (2, -1, 3)),
    (["-z", "x", "-y"], (1, 2, 3), (-3, 1, -2)),
])
def test_axis_mapping_is_the_named_signed_permutation(axes, device_vec, flu_vec):
    out, _, _ = run({"axes": axes}, [ImuBlock.from_arrays(
        [0.0], [device_vec], [device_vec], agent="ff1", device="d", frame="device")])
    assert out[0].accel[0].tolist() == list(flu_vec)
    assert out[0].gyro[0].tolist() == list(flu_vec)


@pytest.mark.parametrize("axes, message", [
    (["x", "y", "-z"], "reflection"), (["x", "x", "z"], "each of x, y, z once"),
    (["x", "y"], "three entries"), (["x", "y", "w"], "x, y or z"),
])
def test_bad_axes_are_refused_with_a_clear_reason(axes, message):
    with pytest.raises(ValidationError, match=message):
        FootImuSensor.Params(axes=axes)


def test_units_g_and_deg_per_s_are_converted():
    block = ImuBlock.from_arrays([0.0], [[0.0, 0.5, 1.0]], [[90.0, 0.0, -180.0]], agent="ff1",
                                 device="d", frame="d")
    out, _, _ = run({"axes": ["x", "y", "z"], "units": {"accel": "g", "gyro": "deg/s"}}, [block])
    np.testing.assert_allclose(out[0].accel[0], [0.0, 0.5 * 9.80665, 9.80665])
    np.testing.assert_allclose(out[0].gyro[0], [np.pi / 2, 0.0, -np.pi])


CALIBRATION = """\
version: 1
devices:
  ff1/imu:
    accel:
      bias: [0.1, -0.2, 0.3]
      scale: [1.01, 0.99, 1.02]
      misalignment: [[1.0, 0.01, -0.02], [0.0, 1.0, 0.03], [0.01, 0.0, 1.0]]
    gyro:
      bias: [0.001, 0.002, -0.003]
default:
  gyro:
    bias: [0.5, 0.5, 0.5]
"""


def test_calibration_is_applied_exactly_per_device_then_rotated(tmp_path):
    (tmp_path / "cal.yaml").write_text(CALIBRATION)
    t, accel, gyro = motion(60)
    msgs = blocks(t, accel, gyro) + blocks(t, accel, gyro, device="ff1/spare")
    out, diags, _ = run({"axes": FRD, "calibration": "cal.yaml"}, msgs, base_dir=tmp_path)
    R = np.diag([1.0, -1.0, -1.0])
    M = np.array([[1.0, 0.01, -0.02], [0.0, 1.0, 0.03], [0.01, 0.0, 1.0]])
    b, s = np.array([0.1, -0.2, 0.3]), np.array([1.01, 0.99, 1.02])
    expected_a = np.array([R @ (M @ (s * (v - b))) for v in accel])
    expected_g = np.array([R @ (v - [0.001, 0.002, -0.003]) for v in gyro])
    main = [x for x in out if x.device == "ff1/imu"]
    np.testing.assert_allclose(joined(main)[1], expected_a, rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(joined(main)[2], expected_g, rtol=1e-13, atol=1e-15)
    spare = [x for x in out if x.device == "ff1/spare"]   # not listed: the default entry
    np.testing.assert_allclose(joined(spare)[2], (gyro - 0.5) @ R.T, atol=1e-15)
    np.testing.assert_allclose(joined(spare)[1], accel @ R.T, atol=1e-15)
    assert diags == []


def test_device_missing_from_a_calibration_without_default_is_reported(tmp_path):
    (tmp_path / "cal.yaml").write_text("devices: {ff9/imu: {}}\n")
    out, diags, _ = run({"axes": FRD, "calibration": str(tmp_path / "cal.yaml")},
                        blocks(*motion(20)))
    assert len(out) == 1
    assert [(d.code, d.level) for d in diags] == [("imu_uncalibrated", "info")]


@pytest.mark.parametrize("text, where, message", [
    ("devices:\n  ff1/imu:\n    accel:\n      scale: [1.0, -1.0, 1.0]\n", ":4:", "positive"),
    ("devices:\n  ff1/imu:\n    gyro:\n      bias: [1, 2]\n", ":4:", "bias"),
    ("devices:\n  ff1/imu:\n    accel:\n      misalignment: [[0,1,0],[1,0,0],[0,0,1]]\n", ":3:",
     "far from the identity"),  # reported at the sensor entry: its validator sees all
    ("devices:\n  ff1/imu:\n    acel: {}\n", ":3:", "acel"),
    ("version: 2\n", ":1:", "version 2"),
])
def test_bad_calibration_files_fail_with_file_line_and_reason(tmp_path, text, where, message):
    path = tmp_path / "cal.yaml"
    path.write_text(text)
    with pytest.raises(ConfigError) as err:
        make_component(FootImuSensor, {"calibration": str(path)})
    assert where in str(err.value) and message in str(err.value)


def test_saturation_above_range_is_refused():
    with pytest.raises(ValidationError, match="must not exceed accel_range"):
        FootImuSensor.Params(screening={"accel_saturation": 500.0, "accel_range": 400.0})


# -- bad samples -------------------------------------------------------------------------

def test_nan_and_inf_samples_are_dropped_counted_and_reported():
    t, accel, gyro = motion(100)
    accel[10, 0] = np.nan
    gyro[20, 2] = np.inf
    t[30] = np.nan
    out, diags, counts = run({}, blocks(t, accel, gyro))
    assert counts == {"nonfinite_samples": 3}
    tk = joined(out)[0]
    assert len(tk) == 97 and not np.isin([t[10], t[20]], tk).any()
    # the first report at once, the rest (within report_interval) summed at the end
    assert [d.code for d in diags] == ["imu_nonfinite"] * 2
    assert [d.text.split(": ")[1].split()[0] for d in diags] == ["1", "2"]


def test_out_of_range_samples_are_dropped():
    t, accel, gyro = motion(100)
    accel[5, 1] = -401.0
    gyro[6, 0] = 45.0
    out, diags, counts = run({}, blocks(t, accel, gyro))
    assert counts == {"out_of_range_samples": 2}
    assert len(joined(out)[0]) == 98
    assert "imu_out_of_range" in [d.code for d in diags]


def test_saturated_samples_are_kept_flagged_and_counted():
    t, accel, gyro = motion(100)
    accel[7, 2] = -156.9      # 16 g full scale
    gyro[8, 1] = 34.9
    out, diags, counts = run({"screening": {"accel_saturation": 156.9, "gyro_saturation": 34.9}},
                             blocks(t, accel, gyro))
    tk, _, _, flags = joined(out)
    assert len(tk) == 100 and counts == {"saturated_samples": 2}
    assert np.flatnonzero(flags & SAT).tolist() == [7, 8]
    assert "imu_saturated" in [d.code for d in diags]


def test_exact_duplicates_are_dropped_within_and_across_blocks():
    t, accel, gyro = motion(60)
    b1 = ImuBlock.from_arrays(t[:30], accel[:30], gyro[:30], agent="ff1", device="d", frame="d")
    idx = np.r_[29, 30:45, 44, 45:60]   # repeats the last of b1, and sample 44 inside b2
    b2 = ImuBlock.from_arrays(t[idx], accel[idx], gyro[idx], agent="ff1", device="d", frame="d")
    out, diags, counts = run({}, [b1, b2])
    assert counts == {"duplicate_samples": 2}
    assert np.array_equal(joined(out)[0], t)
    assert diags == []  # harmless: counted only


def test_time_going_backwards_is_dropped_and_reported():
    t, accel, gyro = motion(100)
    t[50] = t[45]          # back in time, with other values
    t[70] = t[69]          # same time as its predecessor, other values
    out, diags, counts = run({}, blocks(t, accel, gyro))
    assert counts == {"time_backwards_samples": 2}
    tk = joined(out)[0]
    assert len(tk) == 98 and np.all(np.diff(tk) > 0)
    assert "imu_time_backwards" in [d.code for d in diags]


@pytest.mark.parametrize("where", [37, 39, 40])  # inside a block, last of one, first of next
def test_a_single_corrupt_timestamp_is_dropped_not_the_data_after_it(where):
    t, accel, gyro = motion(100)
    t[where] += 1000.0
    out, diags, counts = run({}, blocks(t, accel, gyro))
    assert counts == {"time_outlier_samples": 1}
    tk = joined(out)[0]
    assert len(tk) == 99 and tk[-1] == t[-1]


def test_gaps_are_flagged_on_the_next_sample_counted_and_reported_with_length():
    t, accel, gyro = motion(200)
    keep = np.r_[0:50, 62:200]          # 12 samples lost: a 65 ms step
    out, diags, counts = run({"screening": {"gap": 0.05}}, blocks(t[keep], accel[keep], gyro[keep]))
    tk, _, _, flags = joined(out)
    assert counts == {"gaps": 1} and len(tk) == 188
    assert np.flatnonzero(flags & GAP).tolist() == [50]
    [d] = [d for d in diags if d.code == "imu_gaps"]
    assert "longest 0.07 s" in d.text and d.level == "warning"


def test_a_trailing_gap_sample_waits_for_its_successor_and_is_kept_at_the_end():
    t, accel, gyro = motion(40)
    t[20:] += 5.0   # a real 5 s gap that starts a block
    msgs = [ImuBlock.from_arrays(t[:21], accel[:21], gyro[:21], agent="ff1", device="d", frame="d"),
            ImuBlock.from_arrays(t[21:], accel[21:], gyro[21:], agent="ff1", device="d", frame="d")]
    out, _, counts = run({}, msgs)
    assert counts == {"gaps": 1}
    assert np.array_equal(joined(out)[0], t)
    out, _, counts = run({}, msgs[:1])       # and at the end of the input
    assert np.array_equal(joined(out)[0], t[:21]) and counts == {"gaps": 1}


def test_reports_are_rate_limited_but_counts_are_not():
    t, accel, gyro = motion(8000)            # 40 s at 200 Hz
    accel[::100, 0] = np.nan                  # 80 bad samples, every 0.5 s
    out, diags, counts = run({"report_interval": 10.0}, blocks(t, accel, gyro))
    assert counts == {"nonfinite_samples": 80}
    reports = [d for d in diags if d.code == "imu_nonfinite"]
    assert 4 <= len(reports) <= 6
    assert sum(int(d.text.split(": ")[1].split()[0]) for d in reports) == 80


def test_reset_forgets_the_agent():
    t, accel, gyro = motion(40)
    comp, rec, stats = make_component(FootImuSensor, {})
    comp.handle("in", blocks(t, accel, gyro, size=40)[0])
    comp.reset("ff1")
    comp.handle("in", blocks(t - 10, accel, gyro, size=40)[0])   # earlier times, accepted
    comp.finish()
    assert sum(len(b) for b in rec.on("imu")) == 80 and not stats.counts["under_test"]


# -- at-rest checks ------------------------------------------------------------------------

def test_wrong_axes_are_diagnosed_at_rest():
    t, accel, gyro = motion(200)
    _, diags, _ = run({"axes": ["x", "y", "z"]}, blocks(t, accel, gyro))  # z-down device
    assert [d.code for d in diags] == ["imu_axes_check"]
    assert "[x, -y, -z]" in diags[0].text


def test_accel_in_g_declared_as_si_is_diagnosed():
    t, accel, gyro = motion(200)
    _, diags, _ = run({"axes": FRD}, blocks(t, accel / 9.80665, gyro))
    assert "imu_units_check" in [d.code for d in diags]
    assert "units: {accel: g}" in next(d.text for d in diags if d.code == "imu_units_check")


# -- frame inputs ------------------------------------------------------------------------

def test_can_frames_become_flu_blocks_equal_to_the_samples_within_quantisation():
    t, accel, gyro = motion(300, t0=1000.0)
    frames = to_raw_frames(encode_can_imu(t, accel, gyro, node=2), transport="can",
                           device="can0")
    receive = [RawFrame(t=f.t - 990.0 + 0.002 * np.sin(i), transport="can", channel=f.channel,
                        data=f.data, device="can0") for i, f in enumerate(frames)]  # jitter
    out, diags, counts = run({"axes": FRD,
                              "frames": {"agent_map": {"can0/node2": "ff3/left_foot"}}}, receive)
    assert counts == {} and diags == []
    assert {(b.agent, b.device) for b in out} == {("ff3", "ff3/left_foot")}
    # frames are decoded in batches of < block_s (0.1 s) of frame time: a block's sample
    # times span that, plus the receive jitter (4 ms) and a sample begun in the batch before
    spans = [b.time[-1] - b.time[0] for b in out]
    assert max(spans) < 0.1 + 0.004 + 0.005 and len(out) >= len(t) * 0.005 / 0.1
    tk, a, g, _ = joined(out)
    offset = receive[2].t - t[0]   # anchored by the frame that completes the first sample
    np.testing.assert_allclose(tk, t + offset, atol=1e-6)  # device clock, not the jitter
    np.testing.assert_allclose(a, accel * [1, -1, -1], atol=0.0025 + 1e-9)
    np.testing.assert_allclose(g, gyro * [1, -1, -1], atol=0.00025 + 1e-9)


def test_mavlink_highres_ids_tell_the_two_feet_apart():
    t, accel, gyro = motion(100, t0=50.0)
    left = encode_mavlink_imu(t, accel, gyro, imu_id=0)
    right = encode_mavlink_imu(t, accel + 1.0, gyro, imu_id=1)
    frames = to_raw_frames([f for pair in zip(left, right) for f in pair],
                           transport="mavlink", device="sys1/comp1")
    out, _, counts = run({"axes": FRD, "frames": {"agent_map": {
        "sys1/comp1/imu0": "ff1/left", "sys1/comp1/imu1": "ff1/right"}}}, frames)
    assert counts == {}
    by_device = {d: [b for b in out if b.device == d] for d in ("ff1/left", "ff1/right")}
    np.testing.assert_allclose(joined(by_device["ff1/right"])[1]
                               - joined(by_device["ff1/left"])[1],
                               np.tile([1.0, -1.0, -1.0], (100, 1)), atol=1e-5)


def test_two_unmapped_devices_are_not_merged_into_one_stream():
    t, accel, gyro = motion(40)
    frames = to_raw_frames(encode_can_imu(t, accel, gyro, node=0)
                           + encode_can_imu(t, accel, gyro, node=1), transport="can",
                           device="can0")
    out, diags, counts = run({"frames": {"default_agent": "ff2"}}, frames)
    assert {b.device for b in out} == {"ff2/imu", "ff2/can0/node1"}
    assert counts == {} and [d.code for d in diags] == ["imu_device_clash"]


def test_frame_agent_from_the_source_is_used_when_agent_map_is_silent():
    t, accel, gyro = motion(40)
    frames = [RawFrame(t=f.t, agent="ff5", transport="can", channel=f.channel, data=f.data,
                       device="can0") for f in encode_can_imu(t, accel, gyro, node=4)]
    out, _, _ = run({"frames": {"agent_map": {"can0/node0": "ff1/left"}}}, frames)
    assert {(b.agent, b.device) for b in out} == {("ff5", "ff5/imu")}


def test_text_lines_in_device_units():
    t, accel, gyro = motion(50)
    units = {"accel_unit": "g", "gyro_unit": "deg/s"}
    lines = ImuLinesCodec(units).encode(device_block(t, accel, gyro))
    assert float(lines[0].data.split(b",")[3]) == accel[0, 2] / 9.80665   # in g on the wire
    frames = to_raw_frames(lines, transport="serial", device="/dev/ttyUSB0")
    out, _, counts = run({"axes": FRD, "frames": {"codec_options": {"imu_lines": units}}},
                         frames)
    tk, a, g, _ = joined(out)
    assert counts == {} and out[0].device == "ff1/imu"
    np.testing.assert_allclose(a, accel * [1, -1, -1], rtol=1e-12)
    np.testing.assert_allclose(g, gyro * [1, -1, -1], rtol=1e-12)


def test_bad_frames_are_counted_and_skipped_never_raised():
    t, accel, gyro = motion(10)
    good = to_raw_frames(encode_mavlink_imu(t, accel, gyro), transport="mavlink", device="s")
    raw_imu = encode_mavlink_imu(t[:2], accel[:2], gyro[:2], send="RAW_IMU",
                                 raw_accel_scale=0.01, raw_gyro_scale=0.001)
    bad = [
        RawFrame(t=0.01, transport="mavlink", channel=105, data=good[0].data[:-1] + b"\x00"),
        RawFrame(t=0.01, transport="mavlink", channel=105, data=good[0].data[:15]),
        RawFrame(t=0.01, transport="can", channel=0x100, data=b"\x00\x01"),
        RawFrame(t=0.01, transport="can", channel=0x555, data=bytes(8)),
        RawFrame(t=0.01, transport="can", channel=0x123, data=bytes(8)),
        RawFrame(t=0.01, transport="serial", channel="", data=b"1,2,oops,4,5,6,7"),
        RawFrame(t=0.01, transport="mavlink", channel=0, data=b"\xfd heartbeat"),
        RawFrame(t=0.01, transport="ethercat", channel=1, data=b"?"),
        *to_raw_frames(raw_imu, transport="mavlink", device="s"),
    ]
    out, diags, counts = run({}, bad + good)
    assert counts == {"bad_frames": 4, "unknown_can_ids": 2, "frames_ignored": 2,
                      "raw_imu_unscaled": 2}
    assert sum(len(b) for b in out) == 10
    codes = {d.code: d.level for d in diags}
    assert codes["imu_raw_imu_unscaled"] == "error"
    assert {"imu_bad_frames", "imu_unknown_can_ids"} <= set(codes)


def test_a_device_reboot_reanchors_its_clock_and_is_reported():
    t, accel, gyro = motion(100)
    frames = encode_mavlink_imu(t + 500.0, accel, gyro)[:50] + encode_mavlink_imu(t, accel, gyro)[50:]
    # receive times run on; the device clock restarts from 0.25 s at sample 50
    raw = [RawFrame(t=100.0 + i * 0.005, transport="mavlink", channel=f.channel, data=f.data)
           for i, f in enumerate(frames)]
    out, diags, counts = run({}, raw)
    tk = joined(out)[0]
    # the new clock is confirmed by its second sample: its first one is dropped
    assert counts == {"clock_resyncs": 1, "time_backwards_samples": 1} and len(tk) == 99
    np.testing.assert_allclose(tk, 100.0 + np.delete(np.arange(100), 50) * 0.005, atol=1e-6)
    assert "imu_clock_resyncs" in [d.code for d in diags]


def test_conformance_with_the_plugin_harness():
    t, accel, gyro = motion(20)
    check_plugin(FootImuSensor, {"axes": FRD}, sample_input=[("in", b) for b in blocks(t, accel, gyro)])


# -- codecs by name --------------------------------------------------------------------

def test_frames_are_decoded_by_the_codecs_named_per_transport():
    t, accel, gyro = motion(40)
    frames = to_raw_frames(encode_can_imu(t, accel, gyro, node=1), transport="can",
                           device="can0")
    out, _, counts = run({"frames": {"codecs": {"mavlink": "mavlink_imu"}}}, frames)
    assert out == [] and counts == {"frames_ignored": len(frames)}   # CAN: no codec named
    out, _, counts = run({"frames": {"codecs": {"can": "can_imu"}}}, frames)
    assert sum(len(b) for b in out) == 40 and counts == {}


@pytest.mark.parametrize("frames, message", [
    ({"codecs": {"can": "can_imu_v2"}}, "no codec named 'can_imu_v2'; did you mean 'can_imu'"),
    ({"codecs": {"can": "mavlink_imu"}}, "reads 'mavlink' frames, not 'can'"),
    ({"codecs": {"can": "uwb_can"}}, "decodes TwrReport records; this sensor reads ImuSample"),
    ({"codec_options": {"uwb_lines": {}}}, "options for 'uwb_lines', which no transport uses"),
    ({"codec_options": {"mavlink_imu": {"raw_accel_scale": -1}}},
     "mavlink_imu: raw_accel_scale: Input should be greater than 0"),
    ({"codec_options": {"can_imu": {"dbcfile": "x.dbc"}}}, "dbcfile: Extra inputs"),
])
def test_codec_choices_are_checked_against_the_registry(frames, message):
    with pytest.raises(ValidationError, match=message):
        FootImuSensor.Params(frames=frames)


def test_a_dbc_named_in_the_codec_options_is_read_relative_to_the_pipeline(tmp_path):
    from firenav_framework.codecs.can_database import shipped_dbc
    text = shipped_dbc("firenav_imu.dbc").read_text()
    (tmp_path / "moved.dbc").write_text(text.replace("BO_ 272 IMU1_ACCEL", "BO_ 1536 IMU1_ACCEL"))
    t, accel, gyro = motion(30)
    codec = CanImuCodec({"dbc": "moved.dbc"}, resolve=lambda p: tmp_path / p)
    assert codec.channels("node1") == [0x111, 0x112, 0x600]
    frames = to_raw_frames(codec.encode(device_block(t, accel, gyro), address="node1"),
                           transport="can", device="can0")
    params = {"frames": {"codec_options": {"can_imu": {"dbc": "moved.dbc"}}}}
    out, _, counts = run(params, frames, base_dir=tmp_path)
    assert sum(len(b) for b in out) == 30 and counts == {}
    out, _, counts = run({}, frames)                  # the shipped DBC: 0x600 is unknown
    assert out == [] and counts["unknown_can_ids"] == 30


# -- device clock ----------------------------------------------------------------------

def test_device_clock_keeps_device_time_and_reanchors_only_on_real_jumps():
    clock = DeviceClock(resync=1.0)
    assert clock.to_pipeline(100.0, 5.0) == (5.0, False)
    assert clock.to_pipeline(100.005, 5.013) == (pytest.approx(5.005), False)  # jittery frame
    # a 3 s link stall then a backlog: device time continues, no re-anchor
    assert clock.to_pipeline(100.010, 8.0) == (pytest.approx(5.010), False)
    # reboot: device clock restarts near 0; its next sample confirms the new clock
    t, resynced = clock.to_pipeline(0.002, 8.5)
    assert not resynced and t <= 5.010            # held on the old clock: screened out
    t, resynced = clock.to_pipeline(0.007, 8.505)
    assert resynced and t == pytest.approx(8.505)
    assert clock.to_pipeline(0.012, 8.51) == (pytest.approx(8.51), False)
    # device clock leaps 50 s ahead while frames advance 5 ms
    assert clock.to_pipeline(50.0, 8.515)[1] is False
    t, resynced = clock.to_pipeline(50.005, 8.52)
    assert resynced and t == pytest.approx(8.52)
    assert clock.to_pipeline(float("nan"), 8.53)[1] is False


def test_degraded_mode_decodes_a_firefighter_in_longer_blocks_and_loses_nothing():
    t, accel, gyro = motion(800, t0=50.0)
    frames = to_raw_frames(encode_mavlink_imu(t, accel, gyro), transport="mavlink",
                           device="sys1/comp1")
    comp, rec, _ = make_component(FootImuSensor, {"axes": FRD, "frames": {"block_s": 0.05}})
    for f in frames[:200]:
        comp.handle("raw", f)
    assert comp.degrade("ff2", 1) is None            # not a firefighter of this sensor
    assert comp.degrade("ff1", 1) == "frames decoded in blocks of 0.2 s"
    for f in frames[200:600]:
        comp.handle("raw", f)
    assert comp.degrade("ff1", 0) == "frames decoded in blocks of 0.05 s"
    for f in frames[600:]:
        comp.handle("raw", f)
    comp.finish()
    blocks = rec.on("imu")
    sizes = [len(b) for b in blocks]
    normal = {10, 11}   # 0.05 s of 200 Hz frames, give or take the rounding of frame times
    assert set(sizes[:15]) <= normal and set(sizes[-6:-1]) <= normal
    assert sum(s in (40, 41) for s in sizes) >= 8   # 400 frames in blocks of 0.2 s
    np.testing.assert_allclose(np.concatenate([b.time for b in blocks]), t, atol=1e-6)  # all


def test_clean_blocks_take_the_short_path_with_the_result_of_every_rule():
    from firenav_plugins.sensors.foot_imu.screening import (DeviceHistory, ScreeningLimits,
                                                             apply_rules, screen)
    rng = np.random.default_rng(7)
    limits = ScreeningLimits(accel_saturation=150.0)
    fast, full = DeviceHistory(), DeviceHistory()
    t0 = 0.0
    for k in range(300):
        n = int(rng.integers(1, 25))
        t = t0 + np.cumsum(rng.uniform(0.001, 0.06, n))   # some steps are gaps
        t0 = t[-1]
        accel = rng.normal(0, 60, (n, 3))                   # some saturated, rarely out of range
        gyro = rng.normal(0, 3, (n, 3))
        if k % 7 == 0:
            t[n // 2] = t[max(n // 2 - 1, 0)]                # a repeated time
        flags = (rng.random(n) < 0.05).astype(np.uint8) * IMU_FLAG_BITS["saturated"]
        a, b = screen(t, accel, gyro, limits, fast, flags), apply_rules(t, accel, gyro, limits,
                                                                        full, flags)
        np.testing.assert_array_equal(a.keep, b.keep)
        np.testing.assert_array_equal(a.flags, b.flags)
        assert a.counts == b.counts and a.longest_gap == b.longest_gap
        np.testing.assert_array_equal(fast.times, full.times)
        np.testing.assert_array_equal(fast.values, full.values)


@pytest.mark.parametrize("declared, device_up, suggested", [
    (["x", "-y", "-z"], 2, "[x, y, z]"),       # a z-up device run through foot-ins.yaml
    (["x", "y", "z"], 0, "[-z, y, x]"),        # gravity on the device's x axis
])
def test_the_axes_check_names_the_axes_that_put_gravity_up(declared, device_up, suggested):
    """At rest the specific force points along the device's up axis; under the declared
    axes it reads downwards or sideways, and the check names the mapping that fixes it."""
    t, _, gyro = motion(200)
    up = np.zeros(3)
    up[device_up] = 9.81
    _, diags, _ = run({"axes": declared}, blocks(t, np.tile(up, (len(t), 1)),
                                                  np.zeros_like(gyro)))
    (d,) = [d for d in diags if d.code == "imu_axes_check"]
    assert f"set `axes: {suggested}`" in d.text
    # the suggested mapping really puts gravity on +z
    fixed = axes_matrix([a.strip() for a in suggested[1:-1].split(",")]) @ up
    np.testing.assert_allclose(fixed, [0.0, 0.0, 9.81])
