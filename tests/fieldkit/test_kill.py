"""`firenav run` of field-live.yaml killed with SIGKILL mid-run: its logs replay, and the
replay has every pose the live run had written, identical, then carries on.

The devices are played from this process onto a udp_multicast CAN bus and MAVLink UDP
(the run is another process).
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time

import can
import pytest

from firenav_framework.cli import main
from firenav_framework.transports.mavlink_link import mavutil
from firenav_framework.transports.player import DevicePlayer, Roster

from .conftest import WAIT_S, free_port, wait_for
from .harness import AGENTS, MAV_AGENTS, PIPELINE, simulation
from .test_end_to_end import csv_rows_by_agent

GROUP = "239.74.163.2"


@pytest.fixture
def multicast_port():
    pytest.importorskip("msgpack", reason="python-can's udp_multicast needs msgpack")
    port = free_port()
    try:
        can.Bus(interface="udp_multicast", channel=GROUP, port=port).shutdown()
    except can.CanInitializationError as exc:
        pytest.skip(f"IP multicast unavailable on this machine: {exc}")
    return port


def test_killed_run_replays_to_the_same_poses(tmp_path, multicast_port):
    mav_port, live, replayed = free_port(), tmp_path / "live", tmp_path / "replay"
    local = ["--set", "sinks.live_view.port=0",
             "--set", f"sinks.mavlink_out.url=udpout:127.0.0.1:{free_port()}"]
    run = subprocess.Popen(
        [sys.executable, "-m", "firenav_framework", "run", str(PIPELINE), "--output", str(live),
         "--quiet", *local, "--set", "sources.can.interface=udp_multicast",
         "--set", f"sources.can.channel={GROUP}",
         "--set", f"sources.can.options={{port: {multicast_port}}}",
         "--set", f"sources.mav.url=udpin:127.0.0.1:{mav_port}",
         "--set", "sources.mav.heartbeat_s=0", "--set", "sinks.csv_tracks.flush_every=1"],
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    bus = can.Bus(interface="udp_multicast", channel=GROUP, port=multicast_port)
    conn = mavutil().mavlink_connection(f"udpout:127.0.0.1:{mav_port}", source_system=255)
    stop = threading.Event()
    th = None
    try:
        # the run's links are up once both have recorded what we keep sending (frames
        # the sensors skip: a CAN id outside the IMU layout, a heartbeat of system 250)
        probe = mavutil().mavlink.MAVLink(conn, srcSystem=250, srcComponent=1)

        def links_up() -> bool:
            bus.send(can.Message(arbitration_id=0x7FF, data=b"hello", is_extended_id=False))
            probe.heartbeat_send(0, 0, 0, 0, 0)
            time.sleep(0.2)
            return all(any((live / "raw" / cid).glob(f"*{sfx}")) and
                       any(p.stat().st_size for p in (live / "raw" / cid).glob(f"*{sfx}"))
                       for cid, sfx in (("can", ".log"), ("mav", ".tlog")))
        wait_for(lambda: run.poll() is None and links_up(), timeout=2 * WAIT_S,
                 what="the live run's links")
        player = DevicePlayer(can_bus=bus, mavlink=conn, speed=1.0)
        roster = Roster.of_scenario(simulation().scenario, MAV_AGENTS)
        blocks = (b for _, b in simulation().stream(0.01, {"imu"}))
        th = threading.Thread(target=player.play, args=(blocks, roster, stop), daemon=True)
        th.start()
        csv = live / "ins_pose.csv"
        # kill once every firefighter has a few poses on disk, while the devices still send
        wait_for(lambda: csv.is_file() and all(len(r) >= 3 for r in csv_rows_by_agent(csv).values())
                 and len(csv_rows_by_agent(csv)) == len(AGENTS), timeout=2 * WAIT_S,
                 what="poses of every firefighter in the live CSV")
        os.kill(run.pid, signal.SIGKILL)
        run.wait(WAIT_S)
        killed_during_play = th.is_alive()
    finally:
        stop.set()
        if th is not None:
            th.join(WAIT_S)
        if run.poll() is None:
            run.kill()
        bus.shutdown()
        conn.close()
    assert run.returncode == -signal.SIGKILL
    live_rows = csv_rows_by_agent(csv)

    assert main(["replay", str(live / "raw"), "--pipeline", str(PIPELINE), "--output",
                 str(replayed), "--quiet", *local]) == 0
    replay_rows = csv_rows_by_agent(replayed / "ins_pose.csv")
    for agent in AGENTS:
        rows = live_rows[agent]
        assert replay_rows[agent][:len(rows)] == rows, f"{agent}: replay differs from the live run"
    assert killed_during_play, "the devices had finished before the kill"
