"""Commander outputs: status flags, MAVLink out to a ground station, MCAP recording."""
from __future__ import annotations

import json
import math
import shutil
import socket

import numpy as np
import pytest

from firenav_framework.liveview.status import StatusTracker
from firenav_framework.messages import Diagnostic, PoseEstimate, Tick
from firenav_framework.sinks.mavlink_out import MavlinkOutSink, ned_covariance
from firenav_framework.sinks.mcap_recorder import McapRecorderSink
from firenav_framework.testing import make_component
from firenav_framework.timefmt import wall_text
from firenav_framework.transports.mavlink_link import mavutil

from .conftest import free_port

COV = np.array([[0.5, 0.1, 0.0, 0.01], [0.1, 0.7, 0.0, 0.02],
                [0.0, 0.0, 0.2, 0.0], [0.01, 0.02, 0.0, 0.05]])


def pose(t, agent, x, y, z=0.0, heading=0.0, trusted=True, floor=0):
    return PoseEstimate(t=t, agent=agent, position=np.array([x, y, z]), heading=heading,
                        cov=COV, floor=floor, trusted=trusted)


def test_conditions_follow_silence_stillness_and_trust():
    tr = StatusTracker(stale_after=10.0, man_down_after=30.0, still_radius=0.5,
                       untrusted_after=5.0)
    changes = []
    for k in range(100):          # ff1 walks, ff2 stands still from the start
        t = float(k)
        for c in tr.clock(t) + tr.pose(pose(t, "ff1", 1.0 * k, 0.0)) \
                + tr.pose(pose(t, "ff2", 5.0 + 0.01 * math.sin(k), 5.0)):
            changes.append((t, *c))
    # 30 s of no motion from the first tick at t=0
    assert changes == [(30.0, "ff2", "man_down", True)]
    # ff2's IMU goes silent: a condition of its own, and the man-down stays (silence
    # tells nothing about motion); 40 s later it is still on
    changes = tr.diagnostic(Diagnostic(t=100.0, agent="ff2", device="can0/0x130",
                                       component="can", level="error", code="device_silent",
                                       text=""))
    assert changes == [("ff2", "device_silent", True)]
    changes = []
    for k in range(100, 140):   # ff1 walks on
        changes += tr.clock(float(k)) + tr.pose(pose(float(k), "ff1", 1.0 * k, 0.0))
    assert changes == [] and tr.agents["ff2"].conditions["man_down"]
    # back, and moving: both conditions go
    changes = tr.diagnostic(Diagnostic(t=140.0, agent="ff2", device="can0/0x130",
                                       component="can", level="info", code="device_silent",
                                       text="", active=False))
    assert changes == [("ff2", "device_silent", False)]
    assert tr.pose(pose(140.0, "ff2", 9.0, 5.0)) == [("ff2", "man_down", False)]
    # no pose for stale_after: drawn stale, no condition (a still firefighter's INS
    # publishes nothing)
    assert tr.agents["ff1"].stale(151.0, 10.0) and not any(tr.agents["ff1"].conditions.values())
    # untrusted poses: a condition only after untrusted_after seconds of them
    changes = []
    for k in range(141, 150):   # ff1's poses become untrusted
        for c in tr.clock(float(k)) + tr.pose(pose(float(k), "ff1", 200.0 + k, 0.0,
                                                   trusted=False)):
            changes.append((float(k), *c))
    assert changes == [(146.0, "ff1", "untrusted", True)]  # 5 s after the first, at 141
    assert tr.pose(pose(149.5, "ff1", 351.0, 0.0)) == [("ff1", "untrusted", False)]
    # a map contradiction comes and goes with the estimator's map_error
    on = tr.diagnostic(Diagnostic(t=151.0, agent="ff1", component="pf", level="warning",
                                  code="map_error", text="spread"))
    off = tr.diagnostic(Diagnostic(t=160.0, agent="ff1", component="pf", level="info",
                                   code="map_error", text="", active=False))
    assert on == [("ff1", "map_contradiction", True)]
    assert off == [("ff1", "map_contradiction", False)]


def _receive_all(sock):
    parser = mavutil().mavlink.MAVLink(None)
    parser.robust_parsing = True
    msgs = []
    sock.settimeout(2.0)
    while True:
        try:
            data = sock.recv(65535)
        except socket.timeout:
            return msgs
        msgs += [m for m in parser.parse_buffer(data) or [] if m.get_type() != "BAD_DATA"]


def test_mavlink_out_each_firefighter_is_a_system(tmp_path):
    port = free_port()
    gcs = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    gcs.bind(("127.0.0.1", port))
    sink, _, _ = make_component(MavlinkOutSink, {"url": f"udpout:127.0.0.1:{port}",
                                             "system_ids": {"ff2": 42}}, output_dir=tmp_path)
    sink.start()
    sink.handle("ins.pose", pose(1.0, "ff1", 3.0, 4.0, 1.5, heading=0.3))
    sink.handle("ins.pose", pose(2.0, "ff1", 4.0, 6.0, 1.5, heading=0.3))
    sink.handle("ins.pose", pose(2.0, "ff2", -1.0, 2.0))
    sink.handle("ticks", Tick(t=3.0, period=1.0))
    sink.handle("can.diagnostics", Diagnostic(t=3.5, agent="ff2", component="can",
                                              level="error", code="device_silent", text=""))
    sink.handle("ticks", Tick(t=4.0, period=1.0))
    sink.finish()
    msgs = _receive_all(gcs)
    gcs.close()
    ml = mavutil().mavlink
    lpos = [m for m in msgs if m.get_type() == "LOCAL_POSITION_NED"]
    assert [(m.get_srcSystem(), m.time_boot_ms) for m in lpos] == [(1, 1000), (1, 2000), (42, 2000)]
    # ENU (x east, y north, z up) -> NED
    assert (lpos[1].x, lpos[1].y, lpos[1].z) == pytest.approx((6.0, 4.0, -1.5))
    assert (lpos[1].vx, lpos[1].vy, lpos[1].vz) == pytest.approx((2.0, 1.0, 0.0))
    assert math.isnan(lpos[0].vx)
    odo = [m for m in msgs if m.get_type() == "ODOMETRY"][1]
    yaw = 2 * math.atan2(odo.q[3], odo.q[0])
    assert yaw == pytest.approx(math.pi / 2 - 0.3)
    cov = odo.pose_covariance
    # upper triangle of (n, e, d, roll, pitch, yaw): var_n = var_y, cov_ne = cov_xy, var_yaw
    assert cov[0] == pytest.approx(0.7) and cov[1] == pytest.approx(0.1)
    assert cov[6] == pytest.approx(0.5) and cov[20] == pytest.approx(0.05)
    assert cov[5] == pytest.approx(-0.02) and math.isnan(cov[3])  # n-yaw flips, roll unknown
    assert ned_covariance(COV)[11] == pytest.approx(0.2)  # var_d
    beats = [(m.get_srcSystem(), m.system_status) for m in msgs if m.get_type() == "HEARTBEAT"]
    assert beats[:2] == [(1, ml.MAV_STATE_ACTIVE), (42, ml.MAV_STATE_ACTIVE)]
    assert (42, ml.MAV_STATE_CRITICAL) in beats[2:]
    # a type a GCS lists (QGroundControl ignores autopilot INVALID)
    assert {(m.type, m.autopilot) for m in msgs if m.get_type() == "HEARTBEAT"} == \
        {(ml.MAV_TYPE_GROUND_ROVER, ml.MAV_AUTOPILOT_GENERIC)}
    texts = [(m.get_srcSystem(), m.text, m.severity) for m in msgs
             if m.get_type() == "STATUSTEXT"]
    assert texts == [(42, "ff2 DEVICE SILENT since t=3.5 s", ml.MAV_SEVERITY_CRITICAL)]
    # no plan, so no georeference: nothing global
    assert not [m for m in msgs if m.get_type() in ("GLOBAL_POSITION_INT", "GPS_GLOBAL_ORIGIN")]


def test_mcap_has_schemas_and_survives_truncation(tmp_path):
    from mcap.reader import NonSeekingReader, make_reader

    sink, _, _ = make_component(McapRecorderSink, {"chunk_kb": 1}, output_dir=tmp_path)
    sink.start()
    poses = [pose(0.1 * k, f"ff{k % 3}", k, -k, heading=0.01 * k) for k in range(300)]
    for p in poses:
        sink.handle("ins.pose", p)
    sink.handle("ins.diagnostics", Diagnostic(t=35.0, agent="ff1", component="ins",
                                              level="warning", code="map_error", text="spread"))
    sink.finish()
    path = tmp_path / "fused.mcap"
    with open(path, "rb") as fh:
        reader = make_reader(fh)
        got = [(ch.topic, sch.name, m.data, m.log_time) for sch, ch, m in reader.iter_messages()]
    # one topic per firefighter: the whole estimate as JSON, the pose in Foxglove's schema
    topics = {(g[0], g[1]) for g in got}
    assert {(f"/ins.pose/ff{k}", "firenav.PoseEstimate") for k in range(3)} <= topics
    assert {(f"/ins.pose/ff{k}/pose", "foxglove.PoseInFrame") for k in range(3)} <= topics
    ff1 = [g for g in got if g[0] == "/ins.pose/ff1"]
    assert len(ff1) == 100
    body = json.loads(ff1[2][2])   # the pose k=7
    assert body["agent"] == "ff1" and body["position"] == [7.0, -7.0, 0.0]
    assert np.array(body["cov"]) == pytest.approx(COV) and body["heading"] == pytest.approx(0.07)
    assert ff1[2][3] == round(0.7 * 1e9)
    diag = next(g for g in got if g[0] == "/ins.diagnostics")
    assert diag[1] == "firenav.Diagnostic" and json.loads(diag[2])["code"] == "map_error"
    assert ("/diagnostics", "foxglove.Log") in topics
    # no plan: no walls, no location fixes
    assert not [g for g in got if g[0] == "/building" or g[0].endswith("/fix")]
    # a killed run: no summary, file cut mid-chunk; a streaming reader gets the chunks before
    cut = tmp_path / "cut.mcap"
    shutil.copy(path, cut)
    with open(cut, "r+b") as fh:
        fh.truncate(int(path.stat().st_size * 0.6))
    read = []
    with open(cut, "rb") as fh:
        try:
            for _, ch, m in NonSeekingReader(fh).iter_messages(log_time_order=False):
                if ch.message_encoding == "json" and ch.topic.startswith("/ins.pose/"):
                    read.append(json.loads(m.data)["t"])
        except Exception:  # the torn chunk at the end
            pass
    assert 100 <= len(read) < 300
    assert read == [p.t for p in poses[:len(read)]]


def test_mcap_opens_in_the_mcap_reader_with_foxglove_schemas(tmp_path):
    """Decoded with the mcap reader's protobuf support (the schema bytes the file
    carries, as Foxglove decodes them): poses in frame, location fixes at the plan's
    WGS84 position, the walls of every floor as scene entities, the log."""
    from mcap.reader import make_reader
    from mcap_protobuf.decoder import DecoderFactory

    from firenav_framework.building import bundled_plan, load_building

    building = load_building(bundled_plan("three_storey"))
    sink, _, _ = make_component(McapRecorderSink, {}, building=building, output_dir=tmp_path)
    sink.start()
    sink.handle("pf.pose", pose(1.0, "ff1", 12.0, 5.0, 3.5, heading=0.5, floor=1))
    sink.handle("pf.pose", pose(2.0, "ff2", 3.0, 4.0, 0.0, heading=-1.0, floor=0))
    sink.handle("ins.pose", PoseEstimate(t=2.5, agent="ff1", position=np.array([1.0, 2.0, 0.0]),
                                         heading=0.0, cov=COV, frame="odometry"))
    sink.handle("pf.diagnostics", Diagnostic(t=3.0, agent="ff1", component="pf",
                                             level="error", code="map_error", text="spread"))
    sink.finish()
    with open(tmp_path / "fused.mcap", "rb") as fh:
        reader = make_reader(fh)
        summary = reader.get_summary()
        schemas = {summary.channels[c].topic: summary.schemas[summary.channels[c].schema_id].name
                   for c in summary.channels}
        decoded = {}
        factory = DecoderFactory()
        for schema, ch, m in reader.iter_messages():
            if ch.message_encoding == "protobuf":
                obj = factory.decoder_for("protobuf", schema)(m.data)
            else:
                obj = json.loads(m.data)
            decoded.setdefault(ch.topic, []).append(obj)
    assert schemas["/pf.pose/ff1/pose"] == "foxglove.PoseInFrame"
    assert schemas["/pf.pose/ff1/fix"] == "foxglove.LocationFix"
    assert schemas["/building"] == "foxglove.SceneUpdate"
    assert schemas["/diagnostics"] == "foxglove.Log"
    assert schemas["/pf.pose/ff2"] == "firenav.PoseEstimate"
    pif = decoded["/pf.pose/ff1/pose"][0]
    assert pif.frame_id == "building"
    assert (pif.pose.position.x, pif.pose.position.y, pif.pose.position.z) == (12.0, 5.0, 3.5)
    assert 2 * math.atan2(pif.pose.orientation.z, pif.pose.orientation.w) == pytest.approx(0.5)
    assert (pif.timestamp.seconds, pif.timestamp.nanos) == (1, 0)
    fix = decoded["/pf.pose/ff1/fix"][0]
    want = building.georef.to_wgs84(np.array([[12.0, 5.0, 3.5]]))[0]
    assert (fix.longitude, fix.latitude, fix.altitude) == pytest.approx(tuple(want))
    cov = np.array(fix.position_covariance).reshape(3, 3)   # ENU, turned by the bearing
    assert np.trace(cov[:2, :2]) == pytest.approx(COV[0, 0] + COV[1, 1])
    assert cov[2, 2] == pytest.approx(COV[2, 2])
    # the INS pose is in its own frame: a PoseInFrame there, but no WGS84 fix
    assert decoded["/ins.pose/ff1/pose"][0].frame_id == "odometry"
    assert "/ins.pose/ff1/fix" not in decoded
    (update,) = decoded["/building"]
    assert [e.id for e in update.entities] == ["floor0", "floor1", "floor2"]
    walls = update.entities[1].lines[0]
    assert len(walls.points) == 2 * int((~building.floors[1].wall_is_obstacle).sum())
    assert {p.z for p in walls.points} == {3.5}
    (log,) = decoded["/diagnostics"]
    assert log.name == "pf" and "[map_error] ff1: spread" == log.message


def test_ground_station_reads_wgs84_positions_of_a_georeferenced_plan(tmp_path):
    """pymavlink as the GCS: GLOBAL_POSITION_INT at the plan point's WGS84 position,
    computed independently as a geodesic from the georef's anchor (pyproj.Geod),
    GPS_GLOBAL_ORIGIN at the plan origin, LOCAL_POSITION_NED in true north/east."""
    from pyproj import Geod

    from firenav_framework.building import bundled_plan, load_building

    building = load_building(bundled_plan("three_storey"))  # lat 46.5191, lon 6.5668, 20 deg
    ref = building.georef
    port = free_port()
    gcs = mavutil().mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=255)
    sink, _, _ = make_component(MavlinkOutSink, {"url": f"udpout:127.0.0.1:{port}"},
                                building=building, output_dir=tmp_path)
    sink.start()
    points = [(12.0, 5.0, 0.0), (30.0, 8.0, 3.5), (-4.0, 20.0, 7.0)]
    for k, (x, y, z) in enumerate(points):
        sink.handle("pf.pose", pose(1.0 + k, "ff1", x, y, z, heading=0.0))
    sink.handle("ticks", Tick(t=4.0, period=1.0))
    odometry_frame = PoseEstimate(t=5.0, agent="ff1", position=np.array([1.0, 1.0, 0.0]),
                                  heading=0.0, cov=COV, frame="odometry")
    sink.handle("ins.pose", odometry_frame)  # not in the building: no WGS84 position
    sink.finish()
    got: dict[str, list] = {}
    while True:
        m = gcs.recv_match(blocking=True, timeout=2.0)
        if m is None:
            break
        got.setdefault(m.get_type(), []).append(m)
    gcs.close()
    geod = Geod(ellps="WGS84")
    fixes = got["GLOBAL_POSITION_INT"]
    assert len(fixes) == len(points)
    b = math.radians(ref.bearing)
    for fix, (x, y, z) in zip(fixes, points):
        # plan +y is `bearing` clockwise from north: the point's azimuth and distance
        east = x * math.cos(b) + y * math.sin(b)
        north = -x * math.sin(b) + y * math.cos(b)
        lon, lat, _ = geod.fwd(ref.lon, ref.lat, math.degrees(math.atan2(east, north)),
                               math.hypot(east, north))
        assert fix.lat / 1e7 == pytest.approx(lat, abs=2e-7)   # about 2 cm
        assert fix.lon / 1e7 == pytest.approx(lon, abs=2e-7)
        assert fix.relative_alt == round(z * 1000)
        # heading 0 = plan +x = 90 deg + bearing clockwise from north
        assert fix.hdg == round(100 * (90.0 + ref.bearing)) % 36000
    origin = got["GPS_GLOBAL_ORIGIN"][0]
    assert (origin.latitude / 1e7, origin.longitude / 1e7) == pytest.approx((ref.lat, ref.lon),
                                                                            abs=1e-7)
    local = got["LOCAL_POSITION_NED"][0]
    assert (local.x, local.y) == pytest.approx((-12.0 * math.sin(b) + 5.0 * math.cos(b),
                                                12.0 * math.cos(b) + 5.0 * math.sin(b)))
    assert len(got["LOCAL_POSITION_NED"]) == 4  # the odometry-frame pose too


def _ws_text_frames(sock, want: int, timeout: float = 30.0) -> list[dict]:
    """Read server text frames (JSON) of a WebSocket until ``want`` arrived."""
    import struct
    import time as _time
    buf, out = b"", []
    end = _time.monotonic() + timeout
    sock.settimeout(2.0)
    while len(out) < want and _time.monotonic() < end:
        try:
            got = sock.recv(65536)
        except socket.timeout:
            continue
        if not got:
            break
        buf += got
        while len(buf) >= 2:
            op, n = buf[0] & 0x0F, buf[1] & 0x7F
            head = 2
            if n == 126:
                if len(buf) < 4:
                    break
                n, head = struct.unpack(">H", buf[2:4])[0], 4
            elif n == 127:
                if len(buf) < 10:
                    break
                n, head = struct.unpack(">Q", buf[2:10])[0], 10
            if len(buf) < head + n:
                break
            payload, buf = buf[head:head + n], buf[head + n:]
            if op == 1:
                out.append(json.loads(payload))
    return out


def test_foxglove_live_server_advertises_the_topics_on_loopback(tmp_path):
    """A raw WebSocket client speaking Foxglove's protocol (subprotocol foxglove.sdk.v1)
    sees the server's info and the advertised channels with their schema names."""
    import base64 as b64
    import os

    from firenav_framework.building import bundled_plan, load_building
    from firenav_framework.sinks.foxglove_live import FoxgloveLiveSink

    building = load_building(bundled_plan("three_storey"))
    sink, _, _ = make_component(FoxgloveLiveSink, {"port": 0}, building=building,
                                output_dir=tmp_path)
    sink.start()
    try:
        port = sink.server.port
        sink.handle("pf.pose", pose(1.0, "ff1", 12.0, 5.0, 3.5, floor=1))
        sock = socket.create_connection(("127.0.0.1", port), timeout=30)
        key = b64.b64encode(os.urandom(16)).decode()
        sock.sendall((f"GET / HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nUpgrade: websocket\r\n"
                      f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\n"
                      "Sec-WebSocket-Version: 13\r\nSec-WebSocket-Protocol: foxglove.sdk.v1\r\n\r\n"
                      ).encode())
        head = b""
        while b"\r\n\r\n" not in head:
            head += sock.recv(1)
        assert head.startswith(b"HTTP/1.1 101"), head
        frames = _ws_text_frames(sock, 2)
        sock.close()
    finally:
        sink.finish()
    ops = {f["op"]: f for f in frames}
    assert ops["serverInfo"]["name"].startswith("firenav")
    channels = {c["topic"]: c["schemaName"] for c in ops["advertise"]["channels"]}
    assert channels["/pf.pose/ff1/pose"] == "foxglove.PoseInFrame"
    assert channels["/pf.pose/ff1/fix"] == "foxglove.LocationFix"
    assert channels["/building"] == "foxglove.SceneUpdate"


def test_mavlink_out_silence_never_clears_a_man_down(tmp_path):
    """The issue's case: 'ff3 man down cleared' at INFO when the downed firefighter's
    device went silent. Now the man-down stays, and the heartbeat says EMERGENCY."""
    port = free_port()
    gcs = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    gcs.bind(("127.0.0.1", port))
    sink, _, _ = make_component(MavlinkOutSink, {"url": f"udpout:127.0.0.1:{port}"},
                                output_dir=tmp_path)
    sink.start()
    t0 = 1_764_601_200.0
    for k in range(35):
        sink.handle("ticks", Tick(t=t0 + k, period=1.0))
        sink.handle("pf.pose", pose(t0 + k, "ff3", 4.0, 2.0))
    sink.handle("mav.diagnostics", Diagnostic(t=t0 + 35.5, agent="ff3", device="sys3/comp1",
                                              component="mav", level="error",
                                              code="device_silent", text=""))
    for k in range(36, 80):
        sink.handle("ticks", Tick(t=t0 + k, period=1.0))
    sink.finish()
    msgs = _receive_all(gcs)
    gcs.close()
    ml = mavutil().mavlink
    texts = [(m.text, m.severity) for m in msgs if m.get_type() == "STATUSTEXT"]
    assert texts == [(f"ff3 MAN DOWN since {wall_text(t0 + 30)}", ml.MAV_SEVERITY_EMERGENCY),
                     (f"ff3 DEVICE SILENT since {wall_text(t0 + 35.5)}",
                      ml.MAV_SEVERITY_CRITICAL)]
    beats = [m.system_status for m in msgs if m.get_type() == "HEARTBEAT"]
    first = beats.index(ml.MAV_STATE_EMERGENCY)   # from the tick at t0 + 30 to the end
    assert set(beats[:first]) == {ml.MAV_STATE_ACTIVE}
    assert set(beats[first:]) == {ml.MAV_STATE_EMERGENCY} and len(beats) - first >= 45
