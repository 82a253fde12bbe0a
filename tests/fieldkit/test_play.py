"""`firenav play`: a recording acted out as devices on MAVLink UDP and a CAN bus."""
from __future__ import annotations

import socket
import subprocess
import sys

import numpy as np
import pytest

from firenav_framework.messages import ImuBlock
from firenav_framework.sources.readers.imu_csv import write_imu_csv
from firenav_framework.transports.links import enlarge_receive_buffer
from firenav_framework.transports.mavlink_link import mavutil

from .conftest import free_port

pytest.importorskip("firenav_plugins.sensors.imu_mavlink", reason="IMU frame encoders not installed")


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
