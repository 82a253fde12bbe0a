"""A live run and `firenav replay` of its recordings feed the pipeline identical frames."""
from __future__ import annotations

import socket
import threading
import uuid

import can
import pytest

from firenav_framework.cli import main
from firenav_framework.pipeline import load_pipeline
from firenav_framework.runner import Runner
from firenav_framework.transports.mavlink_link import mavutil

from .conftest import free_port, wait_for

PIPELINE = """
name: field-test
sources:
  - {{id: can, plugin: can_bus, interface: virtual, channel: {channel}, device: can0,
      rotate_mb: 0.01}}
  - {{id: mav, plugin: mavlink, url: "udpin:127.0.0.1:{port}", heartbeat_s: 0}}
sinks:
  - {{plugin: mcap_recorder, input: ["can.raw", "mav.raw"], file: frames.mcap}}
"""


def _mcap(path):
    from mcap.reader import make_reader
    with open(path, "rb") as fh:
        return [(ch.topic, m.log_time, m.data) for _, ch, m in make_reader(fh).iter_messages()]


def test_replay_gives_the_live_runs_frames_byte_for_byte(tmp_path):
    port = free_port()
    channel = f"replay-{uuid.uuid4().hex}"
    pfile = tmp_path / "field.yaml"
    pfile.write_text(PIPELINE.format(channel=channel, port=port))
    runner = Runner(load_pipeline(pfile), output_dir=tmp_path / "live")
    th = threading.Thread(target=runner.run, daemon=True)
    th.start()
    wait_for(lambda: "can" in runner.components and runner.components["can"].link.bus is not None
             and runner.components["mav"].link.conn is not None, what="links open")
    bus = can.Bus(interface="virtual", channel=channel)
    mav = mavutil().mavlink.MAVLink(None, srcSystem=5, srcComponent=1)
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    for k in range(600):
        bus.send(can.Message(arbitration_id=0x100 + k % 3, data=k.to_bytes(4, "little"),
                             is_extended_id=False))
        if k % 3 == 0:
            sock.sendto(mav.highres_imu_encode(k * 1000, k, 0, 9.8, 0, 0, 0, 0, 0, 0, 0, 0, 0,
                                               0, 0, id=0).pack(mav), ("127.0.0.1", port))
    bus.shutdown()
    sock.close()
    frames = lambda cid: runner.stats.counts[cid].get("frames", 0)  # noqa: E731
    wait_for(lambda: frames("can") >= 600 and frames("mav") >= 200, what="all frames")
    runner.stop()
    th.join(60)
    assert not th.is_alive()
    live = _mcap(tmp_path / "live" / "frames.mcap")
    assert sum(1 for t, _, _ in live if t == "/can.raw") == 600
    assert sum(1 for t, _, _ in live if t == "/mav.raw") == 200
    assert len(list((tmp_path / "live" / "raw" / "can").iterdir())) > 1, "rotated"

    assert main(["replay", str(tmp_path / "live" / "raw"), "--pipeline", str(pfile),
                 "--output", str(tmp_path / "replay"), "--quiet"]) == 0
    replayed = _mcap(tmp_path / "replay" / "frames.mcap")
    assert replayed == live


def test_replay_explains_missing_recordings(tmp_path, capsys):
    pfile = tmp_path / "field.yaml"
    pfile.write_text(PIPELINE.format(channel="x", port=1))
    (tmp_path / "raw" / "can").mkdir(parents=True)
    assert main(["replay", str(tmp_path / "raw"), "--pipeline", str(pfile)]) == 2
    err = capsys.readouterr().err
    assert "no recording for source(s) can, mav" in err
