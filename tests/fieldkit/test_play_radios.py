"""`firenav play` sends the radios too: the RFID, barometer and breadcrumb lines of a
scenario on ``--lines``, UWB only where a CAN bus is given (else counted and said)."""
from __future__ import annotations

import socket
import subprocess
import sys
from collections import Counter

import pytest

from firenav_framework.building import load_building
from firenav_framework.codecs import get_codec
from firenav_framework.messages import RawFrame
from firenav_framework.simulator import load_scenario, simulate
from firenav_framework.transports.links import enlarge_receive_buffer

from .all_sensors import SCENARIO
from .conftest import free_port

DURATION = 20.0


def _udp() -> socket.socket:
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind(("127.0.0.1", 0))
    if enlarge_receive_buffer(sock) < 1 << 20:   # read only after the player is done
        pytest.skip("cannot get a 1 MiB UDP receive buffer to hold a burst at --speed 0")
    return sock


def test_play_sends_the_radio_lines_and_says_what_it_could_not_send(tmp_path):
    lines, imus = _udp(), _udp()
    plan = tmp_path / "plan.geojson"
    proc = subprocess.run(
        [sys.executable, "-c", "import sys; from firenav_framework.cli import main; "
         "sys.exit(main())", "play", str(SCENARIO), "--duration", str(DURATION), "--speed", "0",
         "--mavlink", f"udpout:127.0.0.1:{imus.getsockname()[1]}",
         "--lines", f"udp:127.0.0.1:{lines.getsockname()[1]}", "--write-plan", str(plan)],
        capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    got = []
    lines.settimeout(1.0)
    try:
        while True:
            got.append(lines.recv(65535))
    except socket.timeout:
        pass
    lines.close()
    imus.close()

    sim = simulate(load_scenario(SCENARIO), 0, duration_s=DURATION)
    n = Counter({k: len(v) for k, v in sim.messages.items()})
    assert n["uwb"] and n["tags"] and n["rssi"] and n["drops"]
    decoded: Counter = Counter()
    codecs = {name: get_codec(name)() for name in ("rfid_lines", "baro_lines", "breadcrumb_lines")}
    for data in got:
        assert data.endswith(b"\n") and data.count(b"\n") == 1
        frame = RawFrame(t=0.0, transport="udp", channel="", data=data[:-1], device="x")
        kinds = [k for k, c in codecs.items() if c.decode(frame) is not None]
        assert len(kinds) == 1, data
        decoded[kinds[0]] += 1
    assert decoded == {"rfid_lines": n["rfid"] + n["tags"], "baro_lines": n["baro"],
                       "breadcrumb_lines": n["rssi"] + n["drops"]}
    err = proc.stderr
    assert f"skipped {n['uwb']} can frames: no --can link given" in err
    assert "UWB tag ff1 -> TagId 1" in err and "UWB anchor uwb_entrance -> AnchorId 1" in err
    assert f"{len(got)} lines" in err
    assert [a.id for a in load_building(plan).anchors] == ["base", "uwb_entrance"]


@pytest.mark.parametrize("args, message", [
    (["--lines", "udp:nohostport"], "--lines udp:nohostport: UDP line output must be udp:HOST:PORT"),
    (["--lines", "/dev/no-such-port"], "--lines /dev/no-such-port: "),
    (["--write-plan", "/no-such-dir/plan.geojson"], "--write-plan /no-such-dir/plan.geojson: "),
])
def test_a_bad_line_port_or_plan_file_is_a_located_error(args, message):
    proc = subprocess.run(
        [sys.executable, "-c", "import sys; from firenav_framework.cli import main; "
         "sys.exit(main())", "play", str(SCENARIO), "--duration", "1", "--speed", "0",
         "--mavlink", f"udpout:127.0.0.1:{free_port()}", *args],
        capture_output=True, text=True, timeout=300)
    assert proc.returncode == 2 and message in proc.stderr and "Traceback" not in proc.stderr
