"""`firenav play`: a recording acted out as devices on MAVLink UDP and a CAN bus."""
from __future__ import annotations

import socket
import subprocess
import sys

import numpy as np
import pytest

from firenav_framework.formats.imu_csv import write_imu_csv
from firenav_framework.messages import ImuBlock
from firenav_framework.transports.links import enlarge_receive_buffer
from firenav_framework.transports.mavlink_link import mavutil

from .conftest import free_port


def _blocks():
    out = []
    for agent in ("ff1", "ff2"):
        for foot in ("left", "right"):
            t = np.arange(1, 201) * 0.005
            acc = np.tile([0.1, 0.0, -9.81], (200, 1)) + (agent == "ff2")
            gyr = np.tile([0.0, 0.01, 0.0], (200, 1))
            out.append(ImuBlock.from_arrays(t, acc, gyr, agent=agent, device=f"{agent}/{foot}",
                                            frame="device"))
    return out


def test_play_sends_every_sample_as_highres_imu_per_foot(tmp_path):
    path = write_imu_csv(tmp_path / "walk.csv", _blocks())
    port = free_port()
    gcs = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    gcs.bind(("127.0.0.1", port))
    if enlarge_receive_buffer(gcs) < 1 << 20:  # we read only after the player is done
        pytest.skip("cannot get a 1 MiB UDP receive buffer to hold a burst at --speed 0")
    proc = subprocess.run([sys.executable, "-c", "import sys; from firenav_framework.cli import main; "
                           "sys.exit(main())", "play", str(path),
                           "--mavlink", f"udpout:127.0.0.1:{port}", "--speed", "0"],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    parser = mavutil().mavlink.MAVLink(None)
    msgs = []
    gcs.settimeout(1.0)
    try:
        while len(msgs) < 800:
            msgs += parser.parse_buffer(gcs.recv(65535)) or []
    except socket.timeout:
        pass
    gcs.close()
    imu = [m for m in msgs if m.get_type() == "HIGHRES_IMU"]
    assert len(imu) == 800
    per = {(m.get_srcSystem(), m.id) for m in imu}
    assert per == {(1, 0), (1, 1), (2, 0), (2, 1)}
    ff2 = [m for m in imu if m.get_srcSystem() == 2]
    assert ff2[0].zacc == pytest.approx(-8.81, abs=1e-4) and ff2[0].time_usec == 5000


def test_play_a_scenario_in_the_field_live_layout(tmp_path):
    """ff1, ff2 as CAN nodes 1 and 3 (right feet), ff3, ff4 as MAVLink systems 3 and 4."""
    import can

    from firenav_framework.simulator import load_scenario, simulate

    from .harness import SCENARIO
    group, can_port, mav_port = "239.74.163.2", free_port(), free_port()
    try:
        bus = can.Bus(interface="udp_multicast", channel=group, port=can_port)
    except can.CanInitializationError as exc:
        pytest.skip(f"IP multicast unavailable on this machine: {exc}")
    gcs = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    gcs.bind(("127.0.0.1", mav_port))
    if min(enlarge_receive_buffer(gcs), enlarge_receive_buffer(bus._multicast._socket)) < 1 << 20:
        bus.shutdown()
        pytest.skip("cannot get 1 MiB UDP receive buffers to hold a burst at --speed 0")
    proc = subprocess.run([sys.executable, "-m", "firenav_framework", "play", str(SCENARIO),
                           "--can", f"udp_multicast:{group}", "--can-option", f"port={can_port}",
                           "--mavlink", f"udpout:127.0.0.1:{mav_port}",
                           "--mavlink-agents", "ff3,ff4", "--duration", "1", "--speed", "0"],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert "ff1/imu -> CAN node1 (ids 0x110-0x112)" in proc.stderr
    assert "ff3/imu -> MAVLink sys3/comp1/imu1 (msgids 105)" in proc.stderr
    frames = []
    while (m := bus.recv(0.5)) is not None:
        frames.append(m)
    bus.shutdown()
    parser = mavutil().mavlink.MAVLink(None)
    gcs.settimeout(0.5)
    msgs = []
    try:
        while True:
            msgs += parser.parse_buffer(gcs.recv(65535)) or []
    except socket.timeout:
        pass
    gcs.close()

    sim = simulate(load_scenario(SCENARIO), 0, duration_s=1.0)
    n = {a: len(rec.time) for a, rec in sim.imu.items()}
    ids = {m.arbitration_id for m in frames}
    assert ids == {0x110, 0x111, 0x112, 0x130, 0x131, 0x132}
    assert sum(m.arbitration_id == 0x110 for m in frames) == n["ff1"]
    assert sum(m.arbitration_id == 0x130 for m in frames) == n["ff2"]
    for sysid, agent in ((3, "ff3"), (4, "ff4")):
        imu = [m for m in msgs if m.get_type() == "HIGHRES_IMU" and m.get_srcSystem() == sysid]
        rec = sim.imu[agent]
        assert len(imu) == n[agent] and {m.id for m in imu} == {1}
        assert [m.time_usec for m in imu] == [round(t * 1e6) for t in rec.time]
        got = np.array([[m.xacc, m.yacc, m.zacc, m.xgyro, m.ygyro, m.zgyro] for m in imu])
        frd = np.hstack((rec.accel, rec.gyro)) * [1, -1, -1, 1, -1, -1]  # FLU sent as FRD
        np.testing.assert_allclose(got, frd, rtol=1e-6, atol=1e-6)


def test_team_layout_and_its_limits():
    from firenav_framework.codecs import get_codec
    from firenav_framework.transports.player import Assignment, Roster, team_layout
    nodes = get_codec("can_imu")().addresses()       # the reference DBC's eight nodes
    assert nodes == [f"node{n}" for n in range(8)]
    roster = Roster(feet={"ff2/imu": "left"}, mavlink_agents={"ff3"})
    assert roster.assign("ff1", "ff1/right", nodes) == Assignment("can", "node1")
    assert roster.assign("ff1", "ff1/other", nodes) == Assignment("can", "node0")  # free foot
    assert roster.assign("ff2", "ff2/imu", nodes) == Assignment("can", "node2")
    assert roster.assign("ff3", "ff3/imu", nodes) == Assignment("mavlink", "sys3/comp1/imu0")
    with pytest.raises(ValueError, match="no place for a third"):
        roster.assign("ff1", "ff1/hand", nodes)
    assert team_layout(4, 1, False, nodes) == Assignment("can", "node7")
    with pytest.raises(ValueError, match="8 device addresses .* send it over MAVLink"):
        team_layout(5, 0, False, nodes)
    assert team_layout(5, 1, True, nodes) == Assignment("mavlink", "sys5/comp1/imu1")


def test_play_refuses_a_codec_that_cannot_send_imu_on_the_link(tmp_path):
    path = write_imu_csv(tmp_path / "walk.csv", _blocks())
    for spec, reason in (("can=uwb_can", "is not an IMU codec"),
                         ("can=mavlink_imu", "is not an IMU codec"),
                         ("can=can_imu_v2", "no codec named 'can_imu_v2'"),
                         ("serial=imu_lines", "expected can=NAME or mavlink=NAME")):
        proc = subprocess.run([sys.executable, "-m", "firenav_framework", "play", str(path),
                               "--mavlink", "udpout:127.0.0.1:9", "--codec", spec],
                              capture_output=True, text=True, timeout=120)
        assert proc.returncode != 0 and reason in proc.stderr, (spec, proc.stderr)
