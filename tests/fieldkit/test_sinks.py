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


def test_status_flags_follow_silence_stillness_and_trust():
    tr = StatusTracker(stale_after=10.0, man_down_after=30.0, still_radius=0.5)
    changes = []
    for k in range(100):          # ff1 walks, ff2 stands still from the start
        t = float(k)
        changes += tr.clock(t)
        changes += tr.pose(pose(t, "ff1", 1.0 * k, 0.0))
        changes += tr.pose(pose(t, "ff2", 5.0 + 0.01 * math.sin(k), 5.0))
    assert ("ff2", "man_down", True) in changes
    assert not any(a == "ff1" for a, _, _ in changes)
    assert tr.agents["ff2"].flags == {"stale": False, "untrusted": False, "man_down": True}
    # ff1's IMU goes silent: stale at once, and no man-down for a silent device
    changes = tr.diagnostic(Diagnostic(t=100.0, agent="ff1", device="can0/0x110",
                                       component="can", level="error", code="device_silent",
                                       text=""))
    assert changes == [("ff1", "stale", True)]
    changes = []
    for k in range(100, 140):
        changes += tr.clock(float(k))
    assert ("ff1", "man_down", True) not in changes
    changes = tr.diagnostic(Diagnostic(t=140.0, agent="ff1", device="can0/0x110",
                                       component="can", level="info", code="device_silent",
                                       text="", active=False))
    assert ("ff1", "stale", False) not in changes  # still no pose for 40 s: stale remains
    changes = tr.pose(pose(140.0, "ff1", 200.0, 0.0, trusted=False))
    assert ("ff1", "stale", False) in changes and ("ff1", "untrusted", True) in changes


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
    texts = [(m.get_srcSystem(), m.text) for m in msgs if m.get_type() == "STATUSTEXT"]
    assert (42, "ff2 stale ON") in texts


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
