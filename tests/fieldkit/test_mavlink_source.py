"""MAVLink 2 over UDP loopback: frames, heartbeats, corrupt packets, tlog round trip."""
from __future__ import annotations

import socket

from firenav_framework.sources.mavlink_link import MavlinkSource
from firenav_framework.sources.readers import ReadOptions, find_reader
from firenav_framework.transports.mavlink_link import mavutil
from firenav_framework.transports.recorders import log_files

from .conftest import frame_fields, free_port, wait_for

mu = mavutil()


def _imu_packets(sysid: int, n: int) -> list[bytes]:
    """HIGHRES_IMU of the left (id 0) and right (id 1) foot of one system."""
    mav = mu.mavlink.MAVLink(None, srcSystem=sysid, srcComponent=1)
    out = []
    for k in range(n):
        msg = mav.highres_imu_encode(k * 5000, 0.1 * k, 0.0, 9.81, 0.0, 0.0, 0.01 * k,
                                     0, 0, 0, 0, 0, 0, 0, 0x1FF, id=k % 2)
        out.append(msg.pack(mav))
    out.append(mav.heartbeat_encode(mu.mavlink.MAV_TYPE_GENERIC,
                                    mu.mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0).pack(mav))
    return out


def test_udp_frames_errors_and_tlog_replay(running, tmp_path):
    port = free_port()
    src = running(MavlinkSource, {"url": f"udpin:127.0.0.1:{port}", "heartbeat_s": 0,
                                  "device_agents": {"sys7/*": "ff7"}}, tmp_path, cid="mav")
    wait_for(lambda: src.source.link.conn is not None, what="socket open")
    packets = _imu_packets(7, 200) + _imu_packets(9, 10)
    corrupt = bytearray(packets[3])
    corrupt[-1] ^= 0xFF  # bad CRC
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    for i, pkt in enumerate(packets):
        sock.sendto(pkt, ("127.0.0.1", port))
        if i == 50:
            sock.sendto(bytes(corrupt), ("127.0.0.1", port))
            sock.sendto(b"\x00garbage\x13\x37", ("127.0.0.1", port))
    # several packets in one datagram are all taken
    sock.sendto(b"".join(_imu_packets(11, 3)), ("127.0.0.1", port))
    sock.close()
    wait_for(lambda: len(src.frames()) >= len(packets) + 4, what="all packets")
    src.stop()
    frames = src.frames()
    assert [f.data for f in frames[:len(packets)]] == packets
    assert {f.device for f in frames} == {"sys7/comp1", "sys9/comp1", "sys11/comp1"}
    assert {f.channel for f in frames} == {105, 0}  # HIGHRES_IMU, HEARTBEAT
    assert src.counts()["decode_errors"] >= 2
    health = src.source.monitor.devices
    assert {"sys7/comp1/HIGHRES_IMU/0", "sys7/comp1/HIGHRES_IMU/1"} <= set(health)
    assert health["sys7/comp1/HIGHRES_IMU/0"].agent == "ff7"
    assert health["sys7/comp1/HIGHRES_IMU/0"].frames == 100

    tlogs = log_files(tmp_path / "raw" / "mav", (".tlog",))
    replayed = [m for _, m in find_reader(tlogs[0])(tlogs[0], ReadOptions())]
    assert [frame_fields(f) for f in replayed] == [frame_fields(f) for f in frames]
    # and pymavlink itself reads our tlog, with our receive times
    conn = mu.mavlink_connection(str(tlogs[0]))
    msgs = []
    while (m := conn.recv_msg()) is not None:
        msgs.append(m)
    assert [m.get_msgbuf() for m in msgs] == [f.data for f in frames]
    assert [round(m._timestamp * 1e6) for m in msgs] == [round(f.t * 1e6) for f in frames]


def test_gcs_heartbeat_reaches_a_device_once_it_is_heard(running, tmp_path):
    port = free_port()
    src = running(MavlinkSource, {"url": f"udpin:127.0.0.1:{port}", "heartbeat_s": 0.05,
                                  "record": False}, tmp_path, cid="mav")
    wait_for(lambda: src.source.link.conn is not None, what="socket open")
    dev = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    dev.settimeout(0.2)
    parser = mu.mavlink.MAVLink(None)
    heard = []

    def device_heard_heartbeat() -> bool:
        dev.sendto(_imu_packets(3, 1)[-1], ("127.0.0.1", port))
        try:
            data = dev.recv(2048)
        except socket.timeout:
            return False
        heard.extend(parser.parse_buffer(data) or [])
        return any(m.get_type() == "HEARTBEAT" for m in heard)

    wait_for(device_heard_heartbeat, what="a GCS heartbeat at the device")
    dev.close()
    src.stop()
    hb = next(m for m in heard if m.get_type() == "HEARTBEAT")
    assert hb.type == mu.mavlink.MAV_TYPE_GCS and hb.get_srcSystem() == 255


def test_a_truncated_datagram_loses_only_its_own_packet(running, tmp_path):
    port = free_port()
    src = running(MavlinkSource, {"url": f"udpin:127.0.0.1:{port}", "heartbeat_s": 0},
                  tmp_path, cid="mav")
    wait_for(lambda: src.source.link.conn is not None, what="socket open")
    packets = _imu_packets(4, 20)[:-1]
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    for i, pkt in enumerate(packets):
        sock.sendto(pkt[:20] if i in (5, 12) else pkt, ("127.0.0.1", port))
    sock.close()
    wait_for(lambda: len(src.frames()) >= 18, what="the intact packets")
    wait_for(lambda: src.counts().get("decode_errors", 0) >= 2, what="both truncations counted")
    src.stop()
    assert [f.data for f in src.frames()] == [p for i, p in enumerate(packets) if i not in (5, 12)]
    assert src.source.monitor.decode_errors == {"bad_data/truncated": 2}


def test_framing_checks_the_crc_like_pymavlink():
    import random

    from pymavlink.generator.mavcrc import x25crc_slow

    from firenav_framework.transports.mavlink_packets import dialect, split_packets
    pkt = _imu_packets(2, 1)[0]
    body = 10 + pkt[1]
    rng = random.Random(4)
    for _ in range(200):  # random payloads with pymavlink's CRC pass, flipped bits do not
        data = bytearray(pkt)
        data[10:body] = bytes(rng.randrange(256) for _ in range(body - 10))
        crc = x25crc_slow(bytes(data[1:body]))
        crc.accumulate(bytes([dialect().crc_extra[105]]))
        data[body:body + 2] = crc.crc.to_bytes(2, "little")
        assert split_packets(bytes(data)).packets == [bytes(data)]
        k = rng.randrange(1, body + 2)
        data[k] ^= 1 << rng.randrange(8)
        assert split_packets(bytes(data)).packets == []
    # garbage around packets, a message id the dialect does not know, a cut packet
    unknown = bytearray(pkt)
    unknown[7:10] = (0xFFFF00).to_bytes(3, "little")
    res = split_packets(b"xx" + pkt + bytes(unknown) + pkt + b"\x01\x02" + pkt + pkt[:-3])
    assert res.packets == [pkt, pkt, pkt]
    assert (res.garbage, res.bad_crc, res.truncated) == (2, 1, 1)
    # a damaged stretch counts once, whatever magic bytes its payload happens to hold
    bad = bytearray(pkt)
    bad[12:20] = b"\xfd\x09\x00\x00\xfe\x05\xfd\xfe"
    res = split_packets(bytes(bad) + pkt)
    assert res.packets == [pkt] and (res.garbage, res.bad_crc, res.truncated) == (0, 1, 0)
