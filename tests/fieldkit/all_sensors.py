"""A live run of ``pipelines/incident-live.yaml`` with every sensor on its link.

The simulator plays ``data/incident_short.yaml`` (three firefighters: RFID tags, UWB,
barometers, breadcrumbs) as the devices would: ff1 and ff2's foot IMUs and every UWB
report on a ``virtual`` CAN bus, ff3's foot IMU over MAVLink UDP, and the RFID,
barometer and breadcrumb radio lines on a pty the pipeline's ``serial_lines`` source
opens. The same scenario run offline through ``pipelines/incident.yaml`` (the
simulator source, the same sensors and estimators) is the reference. Both runs tap
every message on the streams compared.
"""
from __future__ import annotations

import os
import threading
import uuid
from collections import defaultdict
from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import can
import yaml

from firenav_framework.building.geojson_format import write_geojson
from firenav_framework.cli.replay import replay_document
from firenav_framework.messages import Message
from firenav_framework.pipeline import (apply_overrides, load_pipeline, load_pipeline_text,
                                        validate_document)
from firenav_framework.runner import Runner, RunResult
from firenav_framework.simulator import load_scenario, simulate
from firenav_framework.transports.mavlink_link import mavutil
from firenav_framework.transports.player import DevicePlayer, Roster
from firenav_framework.transports.radio_frames import RadioEncoder, plan_anchors

from .conftest import free_port, stop_live, wait_for, wait_for_frames

REPO = Path(__file__).resolve().parents[2]
SCENARIO = Path(__file__).with_name("data") / "incident_short.yaml"
LIVE = REPO / "pipelines" / "incident-live.yaml"
OFFLINE = REPO / "pipelines" / "incident.yaml"
DURATION = 80.0            # s of the scenario played: every tag, three breadcrumbs
MAV_AGENTS = {"ff3"}
#: The sensor and estimator streams compared between the live and the offline run.
STREAMS = ("uwb.range", "rfid.detections", "rfid.deployments", "baro.height", "radio.range",
           "radio.encounters", "radio.moved", "radio.drops", "ins.pose", "dr.pose", "pf.pose",
           "mm.pose", "ekf.pose", "gen.pose", "team.pose")

#: inject(player, t): send anything extra (bad frames) before the message at time t.
Inject = Callable[[DevicePlayer, float], None]


@lru_cache(maxsize=1)
def simulation():
    return simulate(load_scenario(SCENARIO), 0, duration_s=DURATION)


class Tap:
    """Every message published on :data:`STREAMS`, per stream, in publication order."""

    def __init__(self) -> None:
        self.messages: dict[str, list[Message]] = defaultdict(list)

    def __call__(self, stream: str, msg: Message) -> None:
        if stream in STREAMS:
            self.messages[stream].append(msg)


@dataclass
class Run:
    result: RunResult
    messages: dict[str, list[Message]]
    sent: dict[str, int]

    def count(self, component: str, what: str) -> int:
        return self.result.stats.counts.get(component, {}).get(what, 0)


@lru_cache(maxsize=1)
def offline_run() -> Run:
    """``incident.yaml`` on the scenario's first :data:`DURATION` s, without its sinks."""
    doc = yaml.safe_load(OFFLINE.read_text())
    doc["sources"][0].update(scenario=str(SCENARIO), duration=DURATION)
    doc["sinks"] = []
    runner = Runner(load_pipeline_text(yaml.safe_dump(doc), base_dir=OFFLINE.parent))
    tap = Tap()
    runner.bus.taps.append(tap)
    return Run(runner.run(), dict(tap.messages), {})


class _Pty:
    """A pseudo-terminal: the pipeline opens the slave's path, the devices write the master."""

    def __init__(self) -> None:
        self.master, self.slave = os.openpty()
        self.path = os.ttyname(self.slave)

    def write(self, data: bytes) -> None:
        view = memoryview(data)
        while view:
            view = view[os.write(self.master, view):]

    def close(self) -> None:
        os.close(self.master)
        os.close(self.slave)


def live_run(out: Path, inject: Inject | None = None) -> Run:
    """Play the scenario onto the links of a live ``incident-live.yaml`` (speed 1)."""
    sim = simulation()
    plan = out / "plan.geojson"
    out.mkdir(parents=True, exist_ok=True)
    write_geojson(sim.building, plan)
    channel, port, pty = f"incident-{uuid.uuid4().hex}", free_port(), _Pty()
    overrides = [f"building={plan}", "sources.can.interface=virtual",
                 f"sources.can.channel={channel}", f"sources.mav.url=udpin:127.0.0.1:{port}",
                 "sources.mav.heartbeat_s=0", f"sources.lines.url={pty.path}",
                 f"sinks.mavlink_out.url=udpout:127.0.0.1:{free_port()}",
                 "sinks.live_view.port=0"]
    # backpressure off: the comparison is of the full pipeline, never its cheaper mode
    runner = Runner(load_pipeline(LIVE, overrides), output_dir=out, backpressure=False)
    tap = Tap()
    runner.bus.taps.append(tap)
    box: dict = {}
    thread = threading.Thread(target=lambda: box.setdefault("result", runner.run()),
                              daemon=True)
    thread.start()
    bus = conn = None
    try:
        wait_for(lambda: all(getattr(runner.components.get(c), "link", None) is not None
                             for c in ("can", "mav", "lines"))
                 and runner.components["can"].link.bus is not None
                 and runner.components["mav"].link.conn is not None
                 and runner.components["lines"].link.port is not None, what="links open")
        bus = can.Bus(interface="virtual", channel=channel)
        conn = mavutil().mavlink_connection(f"udpout:127.0.0.1:{port}", source_system=255)
        roster = Roster.of_scenario(sim.scenario, MAV_AGENTS)
        player = DevicePlayer(can_bus=bus, mavlink=conn, lines=pty, speed=1.0,
                              radio=RadioEncoder(team=lambda: roster.order,
                                                 anchors=list(plan_anchors(sim.building))))
        messages = (m for _, m in sim.stream(0.01, {"imu", "uwb", "rfid", "tags", "baro",
                                                     "rssi", "drops"}))
        if inject is not None:
            messages = _injecting(player, messages, inject)
        player.play(messages, roster)
        wait_for_frames(runner, player.sent, {"can": "can", "mav": "mavlink", "lines": "lines"},
                        timeout=120)
    finally:
        stop_live(runner, thread, [bus and bus.shutdown, conn and conn.close, pty.close], 120)
    assert not thread.is_alive(), "the live run did not stop"
    return Run(box["result"], dict(tap.messages), dict(player.sent))


def _injecting(player: DevicePlayer, messages, inject: Inject):
    for msg in messages:
        inject(player, msg.t)
        yield msg


def replay_run(live_out: Path, out: Path) -> dict[str, list[Message]]:
    """``firenav replay`` of a live run's logs (its folder ``live_out``), in this process:
    the tapped messages."""
    doc = replay_document(str(LIVE), live_out / "raw")
    done = apply_overrides(doc, [f"building={live_out / 'plan.geojson'}",
                                 "sinks.live_view.port=0",
                                 f"sinks.mavlink_out.url=udpout:127.0.0.1:{free_port()}"])
    runner = Runner(validate_document(doc, overrides=done), output_dir=out)
    tap = Tap()
    runner.bus.taps.append(tap)
    runner.run()
    return dict(tap.messages)
