"""Live field runs for the end-to-end and fault tests.

The simulator plays ``data/field_team.yaml`` as the devices would (ff1, ff2: CAN
frames of the reference DBC on a ``virtual`` bus; ff3, ff4: HIGHRES_IMU over MAVLink
UDP on loopback), while ``pipelines/field-live.yaml`` runs on those links in this
process (only the links, ports and output are overridden). A *tamper* function can
change what each device sends. The reference is the offline run of the same
scenario: simulator source -> foot_imu -> zupt_ins.

Tolerance of live against offline, and why: the CAN frames quantise accel to 0.005
m/s^2 and gyro to 0.0005 rad/s (MAVLink sends float32), and live pose times are the
device times moved onto the receive clock (UNIX seconds, where a float64 resolves
0.24 us). Propagated through 6 s of walking that is about 0.1 mm and 3e-5 rad; a
stance may also be detected one sample earlier or later, which on the as-worn units
(vibration-rectified gyro bias, boot flex) turns the heading by up to about 1.2 mrad.
So: the same number of poses, times equal up to one constant per device (its first
frame's receive time minus its device time) within one sample period, positions within
5 mm and headings within 2 mrad.
"""
from __future__ import annotations

import math
import socket
import threading
import uuid
from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import can
import numpy as np

from firenav_framework.messages import ImuBlock
from firenav_framework.pipeline import load_pipeline, load_pipeline_text
from firenav_framework.runner import Runner, RunResult, run_pipeline
from firenav_framework.simulator import load_scenario, simulate
from firenav_framework.tracks import Track
from firenav_framework.transports.mavlink_link import mavutil
from firenav_framework.transports.player import DevicePlayer, Roster

from .conftest import free_port, stop_live, wait_for, wait_for_frames

REPO = Path(__file__).resolve().parents[2]
SCENARIO = Path(__file__).with_name("data") / "field_team.yaml"
PIPELINE = REPO / "pipelines" / "field-live.yaml"
MAV_AGENTS = {"ff3", "ff4"}
AGENTS = ("ff1", "ff2", "ff3", "ff4")
SAMPLE_S = 0.01  # the scenario's IMU period
POS_TOL, HEADING_TOL = 5e-3, 2e-3  # m, rad (see the module docstring)

OFFLINE = f"""
name: field-offline
sources: [{{id: sim, plugin: simulator, scenario: {SCENARIO}, seed: 0}}]
sensors: [{{id: imu, plugin: foot_imu, input: sim.imu}}]
estimators: [{{id: ins, plugin: zupt_ins, input: imu.imu}}]
"""

#: tamper(player, block, link, frames): send (or not) one block's encoded frames.
Tamper = Callable[[DevicePlayer, ImuBlock, str, list], None]


def send_as_is(player: DevicePlayer, block: ImuBlock, link: str, frames: list) -> None:
    player.transmit(link, frames)


@lru_cache(maxsize=2)
def simulation(scenario: Path = SCENARIO):
    return simulate(load_scenario(scenario), 0)


@lru_cache(maxsize=1)
def offline_tracks() -> dict[str, Track]:
    """The offline run's zupt_ins poses per agent."""
    result = run_pipeline(load_pipeline_text(OFFLINE, base_dir=REPO))
    return result.tracks["ins.pose"]


def live_overrides(channel: str, port: int, gcs_port: int) -> list[str]:
    """``--set`` values putting field-live.yaml on the test links."""
    return ["sources.can.interface=virtual", f"sources.can.channel={channel}",
            f"sources.mav.url=udpin:127.0.0.1:{port}", "sources.mav.heartbeat_s=0",
            f"sinks.mavlink_out.url=udpout:127.0.0.1:{gcs_port}",
            "sinks.live_view.port=0", "sinks.csv_tracks.flush_every=1"]


@dataclass
class LiveRun:
    result: RunResult
    out: Path
    sent: dict[str, int]
    gcs: list  # MAVLink messages mavlink_out sent to the ground station

    def tracks(self) -> dict[str, Track]:
        return self.result.tracks.get("ins.pose", {})

    def count(self, component: str, what: str) -> int:
        return self.result.stats.counts.get(component, {}).get(what, 0)


class _Gcs:
    """A ground station on a UDP port, collecting what mavlink_out sends."""

    def __init__(self):
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.settimeout(0.2)
        self.port = self.sock.getsockname()[1]
        self.parser = mavutil().mavlink.MAVLink(None)
        self.msgs: list = []
        self._stop = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                data = self.sock.recv(65535)
            except (socket.timeout, OSError):
                continue
            self.msgs += self.parser.parse_buffer(data) or []

    def close(self) -> list:
        self._stop.set()
        self.thread.join(5)
        self.sock.close()
        return self.msgs


def run_live(out: Path, *, speed: float = 2.0, tamper: Tamper = send_as_is,
             extra_overrides: tuple[str, ...] = (), pipeline: Path = PIPELINE,
             scenario: Path = SCENARIO,
             during: Callable[[Runner], None] | None = None) -> LiveRun:
    """Play the scenario onto the links of a live run of ``pipeline`` (field-live.yaml by
    default); ``during(runner)`` starts anything else the run should receive (it returns
    at once) once the links are open. Returns the run."""
    channel, port = f"fieldkit-{uuid.uuid4().hex}", free_port()
    gcs = _Gcs()
    spec = load_pipeline(pipeline, live_overrides(channel, port, gcs.port) + list(extra_overrides))
    runner = Runner(spec, output_dir=out)
    box: dict = {}
    thread = threading.Thread(target=lambda: box.setdefault("result", runner.run()),
                              daemon=True)
    thread.start()
    bus = conn = None
    try:
        wait_for(lambda: getattr(runner.components.get("can"), "link", None) is not None
                 and runner.components["can"].link.bus is not None
                 and runner.components["mav"].link.conn is not None, what="links open")
        bus = can.Bus(interface="virtual", channel=channel)
        conn = mavutil().mavlink_connection(f"udpout:127.0.0.1:{port}", source_system=255)
        player = DevicePlayer(can_bus=bus, mavlink=conn, speed=speed)
        sim = simulation(scenario)
        roster = Roster.of_scenario(sim.scenario, MAV_AGENTS)
        if during is not None:
            during(runner)
        for _, block in sim.stream(0.01, {"imu"}):
            player.assignment(block, roster)
            player.pace(block.t)
            encoded = player.encode(block)
            tamper(player, block, *encoded)
        wait_for_frames(runner, player.sent, {"can": "can", "mav": "mavlink"}, timeout=60)
    finally:
        stop_live(runner, thread, [bus and bus.shutdown, conn and conn.close], 60)
        msgs = gcs.close()
    assert not thread.is_alive(), "the live run did not stop"
    return LiveRun(box["result"], out, dict(player.sent), msgs)


def device_offset(live: Track, offline: Track) -> float:
    """The constant that moves an offline pose time onto the live clock (median)."""
    return float(np.median(live.t - offline.t))


def assert_matches_offline(live: Track, offline: Track, agent: str) -> None:
    """Live poses of one agent equal the offline ones within the stated tolerance."""
    assert len(live) == len(offline), f"{agent}: {len(live)} live poses, {len(offline)} offline"
    shift = live.t - offline.t - device_offset(live, offline)
    assert np.all(np.abs(shift) <= SAMPLE_S + 1e-6), f"{agent}: pose times {shift}"
    dpos = np.abs(live.position - offline.position).max()
    assert dpos <= POS_TOL, f"{agent}: positions differ by up to {dpos:.4f} m"
    dh = np.abs(np.angle(np.exp(1j * (live.heading - offline.heading)))).max()
    assert dh <= HEADING_TOL, f"{agent}: headings differ by up to {math.degrees(dh):.3f} deg"


def assert_others_intact(run: LiveRun, faulted: set[str]) -> None:
    """Every firefighter not in ``faulted`` has exactly the offline track (within tolerance)."""
    offline = offline_tracks()
    tracks = run.tracks()
    for agent in AGENTS:
        if agent not in faulted:
            assert agent in tracks, f"{agent} has no track"
            assert_matches_offline(tracks[agent], offline[agent], agent)
