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
    from mcap.reader import make_reader
    from mcap.reader import NonSeekingReader

    sink, _, _ = make_component(McapRecorderSink, {"chunk_kb": 1}, output_dir=tmp_path)
    sink.start()
    poses = [pose(0.1 * k, f"ff{k % 3}", k, -k, heading=0.01 * k) for k in range(300)]
    for p in poses:
        sink.handle("ins.pose", p)
    sink.handle("ins.diagnostics", Diagnostic(t=5.0, agent="ff1", component="ins",
                                              level="warning", code="map_error", text="spread"))
    sink.finish()
    path = tmp_path / "fused.mcap"
    with open(path, "rb") as fh:
        reader = make_reader(fh)
        got = [(ch.topic, sch.name, json.loads(m.data), m.log_time)
               for sch, ch, m in reader.iter_messages()]
    pose_rows = [g for g in got if g[0] == "ins.pose"]
    assert len(pose_rows) == 300 and {g[1] for g in pose_rows} == {"firenav.PoseEstimate"}
    body = pose_rows[7][2]
    assert body["agent"] == "ff1" and body["position"] == [7.0, -7.0, 0.0]
    assert np.array(body["cov"]) == pytest.approx(COV) and body["heading"] == pytest.approx(0.07)
    assert pose_rows[7][3] == round(0.7 * 1e9)
    diag = next(g for g in got if g[0] == "ins.diagnostics")
    assert diag[1] == "firenav.Diagnostic" and diag[2]["code"] == "map_error"
    # a killed run: no summary, file cut mid-chunk; a streaming reader gets the chunks before
    cut = tmp_path / "cut.mcap"
    shutil.copy(path, cut)
    with open(cut, "r+b") as fh:
        fh.truncate(int(path.stat().st_size * 0.6))
    read = []
    with open(cut, "rb") as fh:
        try:
            for _, ch, m in NonSeekingReader(fh).iter_messages(log_time_order=False):
                read.append(json.loads(m.data)["t"])
        except Exception:  # the torn chunk at the end
            pass
    assert 100 <= len(read) < 300
    assert read == [p.t for p in poses[:len(read)]]


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
