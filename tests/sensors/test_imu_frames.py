"""Foot-IMU frame codecs: CAN (DBC), MAVLink and text lines round trips, bad frames.

Round trips compare decoded samples with the originals within the quantisation the
wire format documents (CAN 0.005 m/s^2 and 0.0005 rad/s; SCALED_IMU 1 milli-g and
1 mrad/s; HIGHRES_IMU float32), and every malformed frame must raise FrameError
with the code it is counted under, never another exception.
"""
from __future__ import annotations

import numpy as np
import pytest

from firenav_framework.messages import IMU_FLAG_BITS, RawFrame
from firenav_plugins.sensors.imu_can import (DBC_PATH, CanImuDecoder, can_ids, encode_can_imu,
                                             load_imu_dbc)
from firenav_plugins.sensors.imu_frames import (DeviceClock, FrameError, LineImuDecoder,
                                                encode_imu_lines, to_raw_frames)
from firenav_plugins.sensors.imu_mavlink import (G0, MAVLINK_IMU_IDS, MavlinkImuDecoder,
                                                 encode_mavlink_imu)

SAT = IMU_FLAG_BITS["saturated"]


def samples(n=400, seed=0, t0=12.0, rate=200.0):
    rng = np.random.default_rng(seed)
    t = t0 + np.arange(n) / rate
    accel = rng.normal(0, 25, (n, 3))
    gyro = rng.normal(0, 4, (n, 3))
    mag = rng.normal(0, 40, (n, 3))
    return t, accel, gyro, mag


def decode_all(decoder, frames):
    out = []
    for f in frames:
        got = decoder.decode(f)
        out.extend(got or [])
    return out


def arrays(decoded):
    t = np.array([s.t for s in decoded])
    a = np.array([s.accel for s in decoded])
    g = np.array([s.gyro for s in decoded])
    return t, a, g


# -- CAN -------------------------------------------------------------------------------

def test_shipped_dbc_is_package_data_with_the_documented_layout():
    assert DBC_PATH.is_file()
    db = load_imu_dbc()
    ids = can_ids(db)
    assert len(ids) == 24
    for node in range(8):
        for k, kind in enumerate(("ACCEL", "GYRO", "TIME")):
            assert ids[0x100 + 0x10 * node + k] == (node, kind)
    for msg in db.messages:
        assert msg.length == 8 and not msg.is_extended_frame
    acc = db.get_message_by_name("IMU0_ACCEL").get_signal_by_name("AccX")
    gyr = db.get_message_by_name("IMU0_GYRO").get_signal_by_name("GyroX")
    assert (acc.scale, acc.length, acc.is_signed) == (0.005, 16, True)
    assert (gyr.scale, gyr.length, gyr.is_signed) == (0.0005, 16, True)


def test_can_round_trip_within_quantisation():
    t, accel, gyro, _ = samples()
    frames = to_raw_frames(encode_can_imu(t, accel, gyro, node=5), transport="can",
                           device="can1")
    assert [f.channel for f in frames[:3]] == [0x150, 0x151, 0x152]
    decoded = decode_all(CanImuDecoder(), frames)
    assert len(decoded) == len(t)
    assert {s.device for s in decoded} == {"can1/node5"}
    td, ad, gd = arrays(decoded)
    assert np.max(np.abs(td - t)) <= 0.5e-6 + 1e-9        # microsecond clock
    assert np.max(np.abs(ad - accel)) <= 0.005 / 2 + 1e-9
    assert np.max(np.abs(gd - gyro)) <= 0.0005 / 2 + 1e-9
    assert not any(s.flags for s in decoded)


def test_can_saturation_is_clipped_and_flagged():
    t, accel, gyro, _ = samples(10)
    accel[3, 1] = 200.0      # beyond +-163.84 m/s^2
    gyro[6, 2] = -30.0       # beyond +-16.384 rad/s
    decoded = decode_all(CanImuDecoder(), to_raw_frames(
        encode_can_imu(t, accel, gyro), transport="can", device="can0"))
    flags = [s.flags for s in decoded]
    assert [i for i, f in enumerate(flags) if f & SAT] == [3, 6]
    assert decoded[3].accel[1] == pytest.approx(163.835)
    assert decoded[6].gyro[2] == pytest.approx(-16.384)


def test_can_nodes_interleave_and_a_lost_frame_drops_only_its_sample():
    t, accel, gyro, _ = samples(20)
    a = encode_can_imu(t, accel, gyro, node=0)
    b = encode_can_imu(t, -accel, -gyro, node=1)
    frames = [f for pair in zip(a, b) for f in pair]
    lost = a[3 * 7 + 1]  # node 0, sample 7, GYRO frame
    frames.remove(lost)
    counts = {}
    dec = CanImuDecoder(count=lambda what, n: counts.__setitem__(what, counts.get(what, 0) + n))
    decoded = decode_all(dec, to_raw_frames(frames, transport="can", device="can0"))
    node0 = [s for s in decoded if s.device == "can0/node0"]
    node1 = [s for s in decoded if s.device == "can0/node1"]
    assert len(node1) == 20 and len(node0) == 19
    assert 7 not in [int(round((s.t - t[0]) * 200)) for s in node0]
    assert counts == {"incomplete_samples": 1}
    np.testing.assert_allclose(arrays(node1)[1], -accel, atol=0.0025 + 1e-9)


def test_can_device_clock_unwraps_past_two_to_the_32_microseconds():
    t = 4294.9 + np.arange(100) * 0.005   # crosses 2^32 us = 4294.967296 s
    zeros = np.zeros((100, 3))
    decoded = decode_all(CanImuDecoder(), to_raw_frames(
        encode_can_imu(t, zeros, zeros), transport="can", device="can0"))
    td = np.array([s.t for s in decoded])
    assert np.all(np.diff(td) > 0)
    np.testing.assert_allclose(td, t, atol=1e-6)


@pytest.mark.parametrize("frame, code", [
    (RawFrame(t=0, transport="can", channel=0x100, data=b"\x01\x02\x03"), "bad_frames"),
    (RawFrame(t=0, transport="can", channel=0x100, data=b""), "bad_frames"),
    (RawFrame(t=0, transport="can", channel=0x7FF, data=bytes(8)), "unknown_can_ids"),
    (RawFrame(t=0, transport="can", channel=0x103, data=bytes(8)), "unknown_can_ids"),
    (RawFrame(t=0, transport="can", channel="0x100", data=bytes(8)), "bad_frames"),
])
def test_bad_can_frames_raise_frame_error_with_their_count_name(frame, code):
    with pytest.raises(FrameError) as err:
        CanImuDecoder().decode(frame)
    assert err.value.code == code


def test_can_encoder_refuses_what_it_cannot_send():
    with pytest.raises(ValueError, match="node 9"):
        encode_can_imu([0.0], np.zeros((1, 3)), np.zeros((1, 3)), node=9)
    with pytest.raises(ValueError, match="non-negative"):
        encode_can_imu([-1.0], np.zeros((1, 3)), np.zeros((1, 3)))


def test_a_dbc_without_the_imu_signals_is_rejected(tmp_path):
    bad = tmp_path / "bad.dbc"
    bad.write_text('VERSION ""\n\nNS_ :\n\nBS_:\n\nBU_: X\n\n'
                   'BO_ 256 IMU0_ACCEL: 8 X\n SG_ AccX : 0|16@1- (0.005,0) [-163.84|163.835] "" X\n')
    with pytest.raises(ValueError, match="lacks signals AccY"):
        load_imu_dbc(str(bad))


# -- MAVLink ---------------------------------------------------------------------------

def mav_frames(encoded):
    return to_raw_frames(encoded, transport="mavlink", device="sys3/comp7")


def test_highres_imu_round_trip_in_si_floats_with_imu_id_and_mag():
    t, accel, gyro, mag = samples(50)
    frames = mav_frames(encode_mavlink_imu(t, accel, gyro, mag=mag, imu_id=1, sysid=3,
                                           compid=7))
    assert {f.channel for f in frames} == {105}
    decoded = decode_all(MavlinkImuDecoder(), frames)
    assert {s.device for s in decoded} == {"sys3/comp7/imu1"}
    td, ad, gd = arrays(decoded)
    np.testing.assert_allclose(td, t, atol=1e-6)
    np.testing.assert_allclose(ad, accel, rtol=1e-6, atol=1e-6)      # float32 on the wire
    np.testing.assert_allclose(gd, gyro, rtol=1e-6, atol=1e-7)
    np.testing.assert_allclose([s.mag for s in decoded], mag, rtol=1e-6, atol=1e-5)


@pytest.mark.parametrize("imu_id, msgid", [(0, 26), (1, 116), (2, 129)])
def test_scaled_imu_round_trip_in_milli_g_and_mrad(imu_id, msgid):
    t, accel, gyro, mag = samples(50)
    frames = mav_frames(encode_mavlink_imu(t, accel, gyro, mag=mag, message="SCALED_IMU",
                                           imu_id=imu_id, sysid=3, compid=7))
    assert {f.channel for f in frames} == {msgid}
    decoded = decode_all(MavlinkImuDecoder(), frames)
    assert {s.device for s in decoded} == {f"sys3/comp7/imu{imu_id}"}
    td, ad, gd = arrays(decoded)
    np.testing.assert_allclose(td, t, atol=0.5e-3 + 1e-9)           # time_boot_ms
    assert np.max(np.abs(ad - accel)) <= G0 * 1e-3 / 2 + 1e-9
    assert np.max(np.abs(gd - gyro)) <= 1e-3 / 2 + 1e-9
    assert np.max(np.abs(np.array([s.mag for s in decoded]) - mag)) <= 0.05 + 1e-9


def test_raw_imu_round_trip_with_scales_and_saturation():
    t, accel, gyro, _ = samples(50)
    accel[4, 0] = 400.0  # beyond 32767 counts of 0.01 m/s^2
    kw = dict(raw_accel_scale=0.01, raw_gyro_scale=0.001)
    frames = mav_frames(encode_mavlink_imu(t, accel, gyro, message="RAW_IMU", imu_id=2, **kw))
    decoded = decode_all(MavlinkImuDecoder(**kw), frames)
    assert {s.device for s in decoded} == {"sys1/comp1/imu2"}
    td, ad, gd = arrays(decoded)
    expected = accel.copy()
    expected[4, 0] = 327.67
    assert np.max(np.abs(ad - expected)) <= 0.005 + 1e-9
    assert np.max(np.abs(gd - gyro)) <= 0.0005 + 1e-9
    assert [i for i, s in enumerate(decoded) if s.flags & SAT] == [4]
    assert all(s.mag is None for s in decoded)  # all-zero field: no magnetometer


def test_packets_are_valid_on_a_byte_stream_and_mavlink1_decodes_too():
    from pymavlink.dialects.v10 import common as v1
    from pymavlink.dialects.v20 import common as v2

    t, accel, gyro, _ = samples(20)
    stream = b"".join(f.data for f in encode_mavlink_imu(t, accel, gyro))
    parsed = v2.MAVLink(None).parse_buffer(stream)
    assert [m.get_type() for m in parsed] == ["HIGHRES_IMU"] * 20
    m1 = v1.MAVLink(None, srcSystem=2, srcComponent=1)
    pkt = v1.MAVLink_highres_imu_message(5_000_000, 0.1, -0.2, -9.81, 0.01, 0.02, 0.03,
                                         0, 0, 0, 0, 0, 0, 0, 0x3F).pack(m1)
    assert pkt[0] == 0xFE
    [s] = MavlinkImuDecoder().decode(RawFrame(t=5.0, transport="mavlink", channel=105,
                                              data=bytes(pkt)))
    assert s.device == "sys2/comp1/imu0" and s.t == 5.0
    assert s.accel == pytest.approx((0.1, -0.2, -9.81), abs=1e-6)


def corrupt_crc(pkt: bytes) -> bytes:
    return pkt[:-1] + bytes([pkt[-1] ^ 0xFF])


@pytest.mark.parametrize("mangle", [corrupt_crc, lambda p: p[:20], lambda p: b"\x00" * len(p),
                                    lambda p: p[:10] + bytes([p[10] ^ 0x55]) + p[11:], lambda p: b""])
def test_bad_mavlink_packets_raise_frame_error(mangle):
    t, accel, gyro, _ = samples(1)
    [frame] = mav_frames(encode_mavlink_imu(t, accel, gyro))
    with pytest.raises(FrameError) as err:
        MavlinkImuDecoder().decode(RawFrame(t=0, transport="mavlink", channel=105,
                                            data=mangle(frame.data)))
    assert err.value.code == "bad_frames"


def test_mavlink_message_id_must_match_the_frame_channel_and_others_are_ignored():
    from pymavlink.dialects.v20 import common as v2

    t, accel, gyro, _ = samples(1)
    [highres] = encode_mavlink_imu(t, accel, gyro)
    with pytest.raises(FrameError, match="packet holds HIGHRES_IMU"):
        MavlinkImuDecoder().decode(RawFrame(t=0, transport="mavlink", channel=26,
                                            data=highres.data))
    heartbeat = v2.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3).pack(v2.MAVLink(None))
    assert MavlinkImuDecoder().decode(RawFrame(t=0, transport="mavlink", channel=0,
                                               data=bytes(heartbeat))) is None
    only_scaled = MavlinkImuDecoder(messages=("SCALED_IMU",))
    assert only_scaled.decode(RawFrame(t=0, transport="mavlink", channel=105,
                                       data=highres.data)) is None
    assert MAVLINK_IMU_IDS["SCALED_IMU3"] in only_scaled.ids


def test_raw_imu_without_scales_is_its_own_error():
    t, accel, gyro, _ = samples(1)
    [f] = encode_mavlink_imu(t, accel, gyro, message="RAW_IMU", raw_accel_scale=0.01,
                             raw_gyro_scale=0.001)
    with pytest.raises(FrameError) as err:
        MavlinkImuDecoder().decode(RawFrame(t=0, transport="mavlink", channel=27, data=f.data))
    assert err.value.code == "raw_imu_unscaled"


def test_mavlink_encoder_refuses_what_it_cannot_send():
    one = (np.zeros(1), np.zeros((1, 3)), np.zeros((1, 3)))
    with pytest.raises(ValueError, match="RAW_IMU needs"):
        encode_mavlink_imu(*one, message="RAW_IMU")
    with pytest.raises(ValueError, match="message must be"):
        encode_mavlink_imu(*one, message="ATTITUDE")
    with pytest.raises(ValueError, match="IMUs 0..2"):
        encode_mavlink_imu(*one, message="SCALED_IMU", imu_id=3)


# -- text lines ------------------------------------------------------------------------

def test_text_lines_round_trip_exactly_with_unit_scales():
    t, accel, gyro, mag = samples(30)
    frames = to_raw_frames(encode_imu_lines(t, accel / G0, np.degrees(gyro), mag),
                           transport="serial", device="/dev/ttyUSB0")
    decoded = decode_all(LineImuDecoder(G0, np.pi / 180), frames)
    assert {s.device for s in decoded} == {"/dev/ttyUSB0"}
    td, ad, gd = arrays(decoded)
    assert np.array_equal(td, t)
    np.testing.assert_allclose(ad, accel, rtol=1e-14)
    np.testing.assert_allclose(gd, gyro, rtol=1e-14)
    assert np.array_equal(np.array([s.mag for s in decoded]), mag)


@pytest.mark.parametrize("data, result", [
    (b"t,ax,ay,az,gx,gy,gz", None), (b"# comment", None), (b"  \r\n", None),
    (b"1,2,3", "bad_frames"), (b"1,2,3,4,5,6,x", "bad_frames"), (b"\xff\xfe,1", "bad_frames"),
])
def test_text_line_headers_are_ignored_and_garbage_is_an_error(data, result):
    frame = RawFrame(t=0, transport="serial", channel="", data=data, device="tty")
    if result is None:
        assert LineImuDecoder().decode(frame) is None
    else:
        with pytest.raises(FrameError) as err:
            LineImuDecoder().decode(frame)
        assert err.value.code == result


def test_nan_in_a_text_line_is_passed_on_for_the_screening():
    frame = RawFrame(t=0, transport="udp", channel="", data=b"nan,0,0,9.8,0,0,0", device="h:1")
    [s] = LineImuDecoder().decode(frame)
    assert np.isnan(s.t) and s.accel == (0.0, 0.0, 9.8)


# -- device clock ----------------------------------------------------------------------

def test_device_clock_keeps_device_time_and_reanchors_only_on_real_jumps():
    clock = DeviceClock(resync=1.0)
    assert clock.to_pipeline(100.0, 5.0) == (5.0, False)
    assert clock.to_pipeline(100.005, 5.013) == (pytest.approx(5.005), False)  # jittery frame
    # a 3 s link stall then a backlog: device time continues, no re-anchor
    assert clock.to_pipeline(100.010, 8.0) == (pytest.approx(5.010), False)
    # reboot: device clock restarts near 0
    t, resynced = clock.to_pipeline(0.002, 8.5)
    assert resynced and t == pytest.approx(8.5)
    assert clock.to_pipeline(0.007, 8.505) == (pytest.approx(8.505), False)
    # device clock leaps 50 s ahead while frames advance 5 ms
    t, resynced = clock.to_pipeline(50.0, 8.51)
    assert resynced and t == pytest.approx(8.51)
    assert clock.to_pipeline(float("nan"), 8.52)[1] is False
