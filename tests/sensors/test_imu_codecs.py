"""IMU codecs: CAN (DBC), MAVLink and text lines round trips, bad frames.

Round trips compare decoded samples with the originals within the quantisation the
wire format documents (CAN 0.005 m/s^2 and 0.0005 rad/s; SCALED_IMU 1 milli-g and
1 mrad/s; HIGHRES_IMU float32), and every malformed frame must raise FrameError
with the code it is counted under, never another exception.
"""
from __future__ import annotations

import numpy as np
import pytest

from firenav_framework.codecs import FrameError, get_codec, to_raw_frames
from firenav_framework.codecs.can_database import shipped_dbc
from firenav_framework.codecs.can_imu import CanImuCodec
from firenav_framework.codecs.imu_lines import ImuLinesCodec
from firenav_framework.codecs.mavlink_imu import G0, MAVLINK_IMU_IDS, MavlinkImuCodec
from firenav_framework.messages import IMU_FLAG_BITS, ImuBlock, RawFrame

SAT = IMU_FLAG_BITS["saturated"]


def block(t, accel, gyro, mag=None) -> ImuBlock:
    return ImuBlock.from_arrays(t, accel, gyro, frame="device",
                                mag=None if mag is None else np.asarray(mag, float))


def encode_can(t, accel, gyro, node=0, **options):
    return CanImuCodec(options).encode(block(t, accel, gyro), address=f"node{node}")


def encode_mav(t, accel, gyro, mag=None, address="", **options):
    return MavlinkImuCodec(options).encode(block(t, accel, gyro, mag), address=address)


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
    assert shipped_dbc("firenav_imu.dbc").is_file()
    codec = get_codec("can_imu")()
    ids = codec.ids
    assert len(ids) == 24
    for node in range(8):
        for k, kind in enumerate(("ACCEL", "GYRO", "TIME")):
            assert ids[0x100 + 0x10 * node + k] == (node, kind)
    # the DBC owns the addresses and their ids
    assert codec.addresses() == [f"node{n}" for n in range(8)]
    assert codec.channels("node3") == [0x130, 0x131, 0x132]
    db = codec.db
    for msg in db.messages:
        assert msg.length == 8 and not msg.is_extended_frame
    acc = db.get_message_by_name("IMU0_ACCEL").get_signal_by_name("AccX")
    gyr = db.get_message_by_name("IMU0_GYRO").get_signal_by_name("GyroX")
    assert (acc.scale, acc.length, acc.is_signed) == (0.005, 16, True)
    assert (gyr.scale, gyr.length, gyr.is_signed) == (0.0005, 16, True)


def test_can_round_trip_within_quantisation():
    t, accel, gyro, _ = samples()
    frames = to_raw_frames(encode_can(t, accel, gyro, node=5), transport="can",
                           device="can1")
    assert [f.channel for f in frames[:3]] == [0x150, 0x151, 0x152]
    decoded = decode_all(CanImuCodec(), frames)
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
    decoded = decode_all(CanImuCodec(), to_raw_frames(
        encode_can(t, accel, gyro), transport="can", device="can0"))
    flags = [s.flags for s in decoded]
    assert [i for i, f in enumerate(flags) if f & SAT] == [3, 6]
    assert decoded[3].accel[1] == pytest.approx(163.835)
    assert decoded[6].gyro[2] == pytest.approx(-16.384)


def test_can_nodes_interleave_and_a_lost_frame_drops_only_its_sample():
    t, accel, gyro, _ = samples(20)
    a = encode_can(t, accel, gyro, node=0)
    b = encode_can(t, -accel, -gyro, node=1)
    frames = [f for pair in zip(a, b) for f in pair]
    lost = a[3 * 7 + 1]  # node 0, sample 7, GYRO frame
    frames.remove(lost)
    counts = {}
    dec = CanImuCodec(count=lambda what, n: counts.__setitem__(what, counts.get(what, 0) + n))
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
    decoded = decode_all(CanImuCodec(), to_raw_frames(
        encode_can(t, zeros, zeros), transport="can", device="can0"))
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
        CanImuCodec().decode(frame)
    assert err.value.code == code


def test_can_encoder_refuses_what_it_cannot_send():
    with pytest.raises(ValueError, match="'node9' is not a node of the DBC"):
        encode_can([0.0], np.zeros((1, 3)), np.zeros((1, 3)), node=9)
    with pytest.raises(ValueError, match="non-negative"):
        encode_can([-1.0], np.zeros((1, 3)), np.zeros((1, 3)))


def test_can_sample_counter_continues_per_node_across_encodes():
    codec = CanImuCodec()
    t, accel, gyro, _ = samples(300)
    first = codec.encode(block(t[:200], accel[:200], gyro[:200]), address="node1")
    other = codec.encode(block(t[:5], accel[:5], gyro[:5]), address="node2")
    later = codec.encode(block(t[200:], accel[200:], gyro[200:]), address="node1")
    seq = [codec.db.decode_message(f.channel, f.data)["Seq"] for f in first + later][::3]
    assert seq == [k % 256 for k in range(300)]
    assert codec.db.decode_message(other[0].channel, other[0].data)["Seq"] == 0
    # all 300 samples decode, across the wrap of the counter
    decoded = decode_all(CanImuCodec(), to_raw_frames(first + later, transport="can",
                                                      device="can0"))
    assert len(decoded) == 300


def test_a_dbc_without_the_imu_signals_is_rejected(tmp_path):
    bad = tmp_path / "bad.dbc"
    bad.write_text('VERSION ""\n\nNS_ :\n\nBS_:\n\nBU_: X\n\n'
                   'BO_ 256 IMU0_ACCEL: 8 X\n SG_ AccX : 0|16@1- (0.005,0) [-163.84|163.835] "" X\n')
    with pytest.raises(ValueError, match="lacks signals AccY"):
        CanImuCodec({"dbc": str(bad)})
    with pytest.raises(ValueError, match="no IMU<n>_GYRO message"):
        CanImuCodec({"dbc": "only_accel.dbc"}, resolve=lambda name: _only_accel(tmp_path))


def _only_accel(folder):
    """A DBC with a complete ACCEL message and nothing else."""
    path = folder / "only_accel.dbc"
    signals = "".join(f' SG_ {s} : {16 * i}|16@1- (0.005,0) [-163.84|163.835] "" X\n'
                      for i, s in enumerate(("AccX", "AccY", "AccZ")))
    path.write_text('VERSION ""\n\nNS_ :\n\nBS_:\n\nBU_: X\n\nBO_ 256 IMU0_ACCEL: 8 X\n'
                    + signals + ' SG_ Seq : 48|8@1+ (1,0) [0|255] "" X\n'
                    ' SG_ AccSat : 56|1@1+ (1,0) [0|1] "" X\n'
                    ' SG_ GyroSat : 57|1@1+ (1,0) [0|1] "" X\n')
    return path


# -- MAVLink ---------------------------------------------------------------------------

def mav_frames(encoded):
    return to_raw_frames(encoded, transport="mavlink", device="sys3/comp7")


def test_highres_imu_round_trip_in_si_floats_with_imu_id_and_mag():
    t, accel, gyro, mag = samples(50)
    frames = mav_frames(encode_mav(t, accel, gyro, mag=mag, address="sys3/comp7/imu1"))
    assert {f.channel for f in frames} == {105}
    decoded = decode_all(MavlinkImuCodec(), frames)
    assert {s.device for s in decoded} == {"sys3/comp7/imu1"}
    td, ad, gd = arrays(decoded)
    np.testing.assert_allclose(td, t, atol=1e-6)
    np.testing.assert_allclose(ad, accel, rtol=1e-6, atol=1e-6)      # float32 on the wire
    np.testing.assert_allclose(gd, gyro, rtol=1e-6, atol=1e-7)
    np.testing.assert_allclose([s.mag for s in decoded], mag, rtol=1e-6, atol=1e-5)


@pytest.mark.parametrize("imu_id, msgid", [(0, 26), (1, 116), (2, 129)])
def test_scaled_imu_round_trip_in_milli_g_and_mrad(imu_id, msgid):
    t, accel, gyro, mag = samples(50)
    frames = mav_frames(encode_mav(t, accel, gyro, mag=mag, send="SCALED_IMU",
                                   address=f"sys3/comp7/imu{imu_id}"))
    assert {f.channel for f in frames} == {msgid}
    decoded = decode_all(MavlinkImuCodec(), frames)
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
    frames = mav_frames(encode_mav(t, accel, gyro, send="RAW_IMU", address="sys1/comp1/imu2",
                                   **kw))
    decoded = decode_all(MavlinkImuCodec(kw), frames)
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
    stream = b"".join(f.data for f in encode_mav(t, accel, gyro))
    parsed = v2.MAVLink(None).parse_buffer(stream)
    assert [m.get_type() for m in parsed] == ["HIGHRES_IMU"] * 20
    m1 = v1.MAVLink(None, srcSystem=2, srcComponent=1)
    pkt = v1.MAVLink_highres_imu_message(5_000_000, 0.1, -0.2, -9.81, 0.01, 0.02, 0.03,
                                         0, 0, 0, 0, 0, 0, 0, 0x3F).pack(m1)
    assert pkt[0] == 0xFE
    [s] = MavlinkImuCodec().decode(RawFrame(t=5.0, transport="mavlink", channel=105,
                                              data=bytes(pkt)))
    assert s.device == "sys2/comp1/imu0" and s.t == 5.0
    assert s.accel == pytest.approx((0.1, -0.2, -9.81), abs=1e-6)


def corrupt_crc(pkt: bytes) -> bytes:
    return pkt[:-1] + bytes([pkt[-1] ^ 0xFF])


@pytest.mark.parametrize("mangle", [corrupt_crc, lambda p: p[:20], lambda p: b"\x00" * len(p),
                                    lambda p: p[:10] + bytes([p[10] ^ 0x55]) + p[11:], lambda p: b""])
def test_bad_mavlink_packets_raise_frame_error(mangle):
    t, accel, gyro, _ = samples(1)
    [frame] = mav_frames(encode_mav(t, accel, gyro))
    with pytest.raises(FrameError) as err:
        MavlinkImuCodec().decode(RawFrame(t=0, transport="mavlink", channel=105,
                                            data=mangle(frame.data)))
    assert err.value.code == "bad_frames"


def test_mavlink_message_id_must_match_the_frame_channel_and_others_are_ignored():
    from pymavlink.dialects.v20 import common as v2

    t, accel, gyro, _ = samples(1)
    [highres] = encode_mav(t, accel, gyro)
    with pytest.raises(FrameError, match="packet holds HIGHRES_IMU"):
        MavlinkImuCodec().decode(RawFrame(t=0, transport="mavlink", channel=26,
                                            data=highres.data))
    heartbeat = v2.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3).pack(v2.MAVLink(None))
    assert MavlinkImuCodec().decode(RawFrame(t=0, transport="mavlink", channel=0,
                                             data=bytes(heartbeat))) is None
    only_scaled = MavlinkImuCodec({"messages": ["SCALED_IMU"]})
    assert only_scaled.decode(RawFrame(t=0, transport="mavlink", channel=105,
                                       data=highres.data)) is None
    assert MAVLINK_IMU_IDS["SCALED_IMU3"] in only_scaled.ids


def test_raw_imu_without_scales_is_its_own_error():
    t, accel, gyro, _ = samples(1)
    [f] = encode_mav(t, accel, gyro, send="RAW_IMU", raw_accel_scale=0.01,
                     raw_gyro_scale=0.001)
    with pytest.raises(FrameError) as err:
        MavlinkImuCodec().decode(RawFrame(t=0, transport="mavlink", channel=27, data=f.data))
    assert err.value.code == "raw_imu_unscaled"


def test_mavlink_encoder_refuses_what_it_cannot_send():
    one = (np.zeros(1), np.zeros((1, 3)), np.zeros((1, 3)))
    with pytest.raises(ValueError, match="RAW_IMU needs"):
        encode_mav(*one, send="RAW_IMU")
    with pytest.raises(ValueError, match="send"):
        encode_mav(*one, send="ATTITUDE")
    with pytest.raises(ValueError, match="IMUs 0..2"):
        encode_mav(*one, send="SCALED_IMU", address="sys1/comp1/imu3")
    with pytest.raises(ValueError, match="is not sys<s>/comp<c>/imu<i>"):
        encode_mav(*one, address="node1")


def pymavlink_record(data: bytes):
    """The reference reading of one HIGHRES_IMU packet: pymavlink's own parser."""
    from pymavlink.dialects.v20 import common as v2

    m = v2.MAVLink(None).decode(bytearray(data))
    mag = ((m.xmag * 100, m.ymag * 100, m.zmag * 100)
           if m.fields_updated & 0x1C0 == 0x1C0 else None)
    return (f"sys{m.get_srcSystem()}/comp{m.get_srcComponent()}/imu{m.id}",
            m.time_usec * 1e-6, (m.xacc, m.yacc, m.zacc), (m.xgyro, m.ygyro, m.zgyro), mag)


def test_highres_batches_read_what_pymavlink_reads_and_keep_frame_order():
    from pymavlink.dialects.v10 import common as v1

    t, accel, gyro, mag = samples(12)
    left = mav_frames(encode_mav(t[:6], accel[:6], gyro[:6], mag[:6], "sys3/comp1/imu0"))
    right = mav_frames(encode_mav(t[6:], accel[6:], gyro[6:], None, "sys3/comp1/imu1"))
    scaled = mav_frames(encode_mav(t[:2], accel[:2] / 10, gyro[:2], None, "sys3/comp1/imu0",
                                   send="SCALED_IMU"))
    m1 = v1.MAVLink(None, srcSystem=4, srcComponent=2)
    old = RawFrame(t=0, transport="mavlink", channel=105, data=bytes(
        v1.MAVLink_highres_imu_message(7_000_000, 0.5, 0, -9.8, 0, 0, 0.1, 0, 0, 0, 0, 0, 0,
                                       0, 0x3F).pack(m1)))
    bad = RawFrame(t=0, transport="mavlink", channel=105, data=corrupt_crc(left[1].data))
    heartbeat = RawFrame(t=0, transport="mavlink", channel=0, data=b"\xfd")
    frames = [left[0], right[0], scaled[0], bad, old, heartbeat, *left[2:], scaled[1],
              *right[1:]]
    codec = MavlinkImuCodec()
    decoded = codec.decode_batch(frames)
    expected = [pymavlink_record(f.data) for f in frames if f not in (bad, heartbeat)
                and f.channel == 105]
    got = [(s.device, s.t, s.accel, s.gyro, s.mag)
           for s, i in zip(decoded.records, decoded.origin) if frames[i].channel == 105]
    assert [g[0] for g in got] == [e[0] for e in expected]
    for g, e in zip(got, expected):
        assert g[1] == e[1] and g[2] == e[2] and g[3] == e[3]
        assert (g[4] is None) == (e[4] is None)
        if e[4] is not None:
            assert g[4] == pytest.approx(e[4], rel=1e-12)
    # records in frame order, each naming the frame that completed it
    assert [frames[i].channel for i in decoded.origin] == [
        f.channel for f in frames if f not in (bad, heartbeat)]
    assert [i for i, _ in decoded.problems] == [3] and decoded.ignored == 1
    assert "bad CRC" in str(decoded.problems[0][1])
    # frame by frame, the same records and the same problem
    one_by_one = [s for f in frames if f is not bad for s in (codec.decode(f) or [])]
    assert [(s.device, s.t) for s in one_by_one] == [(s.device, s.t) for s in decoded.records]
    with pytest.raises(FrameError, match="bad CRC"):
        codec.decode(bad)


def test_mavlink_packet_sequence_continues_per_address():
    codec = MavlinkImuCodec()
    t, accel, gyro, _ = samples(10)
    left = codec.encode(block(t[:6], accel[:6], gyro[:6]), address="sys2/comp1/imu0")
    right = codec.encode(block(t[:3], accel[:3], gyro[:3]), address="sys2/comp1/imu1")
    more = codec.encode(block(t[6:], accel[6:], gyro[6:]), address="sys2/comp1/imu0")
    assert [f.data[4] for f in left + more] == list(range(10))   # MAVLink 2 seq byte
    assert [f.data[4] for f in right] == [0, 1, 2]
    assert codec.channels("sys2/comp1/imu1") == [105]


# -- text lines ------------------------------------------------------------------------

def test_text_lines_round_trip_with_unit_scales():
    t, accel, gyro, mag = samples(30)
    codec = ImuLinesCodec({"accel_unit": "g", "gyro_unit": "deg/s"})
    encoded = codec.encode(block(t, accel, gyro, mag))
    first = [float(v) for v in encoded[0].data.split(b",")]
    np.testing.assert_allclose(first[1:7], [*accel[0] / G0, *np.degrees(gyro[0])], rtol=1e-14)
    frames = to_raw_frames(encoded, transport="serial", device="/dev/ttyUSB0")
    decoded = decode_all(codec, frames)
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
        assert ImuLinesCodec().decode(frame) is None
    else:
        with pytest.raises(FrameError) as err:
            ImuLinesCodec().decode(frame)
        assert err.value.code == result


def test_nan_in_a_text_line_is_passed_on_for_the_screening():
    frame = RawFrame(t=0, transport="udp", channel="", data=b"nan,0,0,9.8,0,0,0", device="h:1")
    [s] = ImuLinesCodec().decode(frame)
    assert np.isnan(s.t) and s.accel == (0.0, 0.0, 9.8)
