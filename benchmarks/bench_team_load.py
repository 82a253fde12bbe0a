"""Ten firefighters on the incident pipeline, live: real-time factor and pose latency of
``team_fusion`` through the field kit's outputs (live view, MAVLink out).

The scenario is the ``incident`` with six more firefighters (copies of the kits there:
two more with foot IMUs only, two more breadcrumb crews with UWB and a radio, one more
tag reader following ff1, one more IMU-only searcher) and every crew going in within
the first minute, so all ten are inside at once; it is cut after ``--minutes``. The
pipeline is ``pipelines/incident.yaml`` (every method per firefighter, then
team_fusion), its sinks replaced by the field kit's commander outputs: the live view
(any free port) and MAVLink out to a local UDP port, both fed by ``team.pose``.

Two runs of the same data, one after the other, on the pipeline thread (one core):

* **as fast as possible**: real-time factor = simulated seconds / wall seconds (and
  per CPU second: the pipeline's process time), the cost per fused pose;
* **paced to the wall clock** (the Runner's ``realtime``, as ``firenav replay
  --realtime`` replays a recording): for every ``team.pose`` the pipeline publishes,
  its latency = wall time of publication minus the wall time its data was due (the due
  time of the newest source message dispatched when it was published: how far the kit
  is behind the devices), p50 / p99 / max, goal p99 < 250 ms; also from the pose's own
  time (the stride it is of: adds the INS's stride detection and the fusion's wait for
  the methods' poses), and the worst latency per 10 s window.

With ``--links`` the same ten firefighters come over the field kit's links instead, as a
real kit gets them: ``firenav play`` (another process, acting as the devices) sends ff1 and
ff2's foot IMUs and every UWB report on a CAN bus (python-can ``udp_multicast`` on
loopback), the other eight's foot IMUs over MAVLink UDP, and the RFID, barometer and
breadcrumb radio lines as UDP datagrams, in real time; ``pipelines/incident-live.yaml``,
with its device maps widened to ten firefighters, its lines on ``udp_lines`` and every
sink it has (live view, MAVLink out, CSV, MCAP, diagnostics log, each link's raw
recording), decodes and fuses them with the backpressure a live run has. Latency here is
the receive clock at each ``team.pose`` minus the receive time of the newest frame the
pipeline had taken (how far it is behind the links), and from the pose's own time.

    python benchmarks/bench_team_load.py --minutes 4
    python benchmarks/bench_team_load.py --minutes 4 --links
"""
from __future__ import annotations

import argparse
import copy
import json
import os
import re
import resource
import socket
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_fieldkit_load import _percentiles, _worst_per_window  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
PIPELINE = ROOT / "pipelines" / "incident.yaml"
SCENARIO = ROOT / "firenav_framework" / "simulator" / "scenarios" / "incident.yaml"
#: (new id, the incident's firefighter whose kit and plan it copies, start time [s])
EXTRA = [("ff5", "ff4", 25.0), ("ff6", "ff3", 30.0), ("ff7", "ff4", 40.0),
         ("ff8", "ff2", 0.0), ("ff9", "ff3", 50.0), ("ff10", "ff4", 55.0)]
#: the incident's own crews B and C go in early too
STARTS = {"ff3": 10.0, "ff4": 15.0}


def ten_firefighters() -> dict:
    """The incident scenario with ten firefighters all inside within the first minute."""
    sc = yaml.safe_load(SCENARIO.read_text())
    sc["name"] = "incident_ten"
    by_id = {a["id"]: a for a in sc["agents"]}
    for agent, t in STARTS.items():
        by_id[agent]["start"]["time_s"] = t
        by_id[agent]["sensors"]["imu"]["switch_on_s"] = t - 1.0
    for new, like, t in EXTRA:
        a = copy.deepcopy(by_id[like])
        a["id"] = new
        if "follow" in a:
            a["follow"] = {"agent": "ff1", "lag_s": 4.0}
            a["sensors"]["imu"]["switch_on_s"] = 3.0
        else:
            a["start"]["time_s"] = t
            a["sensors"]["imu"]["switch_on_s"] = t - 1.0
        sc["agents"].append(a)
    return sc


def pipeline(scenario: Path, minutes: float, gcs_port: int, seed: int) -> dict:
    from firenav_framework.pipeline import load_pipeline
    sinks = [{"id": "view", "plugin": "live_view", "port": 0, "input": ["team.pose"]},
             {"id": "gcs", "plugin": "mavlink_out", "url": f"udpout:127.0.0.1:{gcs_port}",
              "input": ["team.pose"]}]
    return load_pipeline(PIPELINE, [f"sources.sim.scenario={scenario}",
                                    f"sources.sim.seed={seed}",
                                    f"sources.sim.duration={minutes * 60.0}",
                                    f"sinks={json.dumps(sinks)}"])


def run(spec, realtime: bool) -> dict:
    from firenav_framework.runner import Runner
    m: dict = {"newest": None, "lat": [], "lat_pose": [], "at": [], "poses": 0}
    runner_box: list = []

    def tap(stream: str, msg) -> None:
        runner = runner_box[0]
        if stream.startswith("sim."):
            m["newest"] = msg.t if m["newest"] is None else max(m["newest"], msg.t)
        elif stream == "team.pose":
            m["poses"] += 1
            if realtime and runner._pace0 is not None:
                wall0, t0 = runner._pace0
                now = time.monotonic()
                m["lat"].append(now - (wall0 + (m["newest"] - t0)))
                m["lat_pose"].append(now - (wall0 + (msg.t - t0)))
                m["at"].append(msg.t - t0)

    class Measured(Runner):
        def build(self) -> None:
            super().build()
            self.bus.taps.append(tap)

    with tempfile.TemporaryDirectory(prefix="bench-team-load-") as out:
        runner = Measured(spec, output_dir=Path(out), realtime=realtime)
        runner_box.append(runner)
        ru0 = resource.getrusage(resource.RUSAGE_SELF)
        w0 = time.monotonic()
        result = runner.run()
        wall = time.monotonic() - w0
        ru1 = resource.getrusage(resource.RUSAGE_SELF)
    cpu = ru1.ru_utime + ru1.ru_stime - ru0.ru_utime - ru0.ru_stime
    return {"sim_s": result.duration_s, "wall_s": wall, "cpu_s": cpu, "poses": m["poses"],
            "agents": len(result.tracks.get("team.pose", {})),
            "faults": len(result.faults), "lat": _percentiles(m["lat"]),
            "lat_pose": _percentiles(m["lat_pose"]),
            "worst_10s": _worst_per_window(m["at"], m["lat"], 10.0)}


LIVE = ROOT / "pipelines" / "incident-live.yaml"
#: the agents whose foot IMUs go over MAVLink (the CAN reference DBC has nodes for four)
CAN_AGENTS = ("ff1", "ff2")


def live_pipeline(plan: Path, agents: list[str], can_port: int, mav_port: int,
                  lines_port: int, gcs_port: int) -> dict:
    """``incident-live.yaml`` for ``agents`` (the scenario's order: UWB tag and MAVLink
    system N are the N-th), on loopback links."""
    doc = yaml.safe_load(LIVE.read_text())
    doc["building"] = str(plan)
    mav = [a for a in agents if a not in CAN_AGENTS]
    number = {a: k + 1 for k, a in enumerate(agents)}
    for src in doc["sources"]:
        if src["id"] == "can":
            src.update(interface="udp_multicast", channel="239.74.163.2",
                       options={"port": can_port})
        elif src["id"] == "mav":
            src.update(url=f"udpin:127.0.0.1:{mav_port}", heartbeat_s=0,
                       device_agents={f"sys{number[a]}/*": a for a in mav})
    doc["sources"] = [s for s in doc["sources"] if s["id"] != "lines"] + [
        {"id": "lines", "plugin": "udp_lines", "bind": f"127.0.0.1:{lines_port}"}]
    for sensor in doc["sensors"]:
        if sensor["id"] == "imu_mav":
            sensor["frames"]["agent_map"] = {
                f"sys{number[a]}/comp1/imu{k}": f"{a}/{foot}"
                for a in mav for k, foot in enumerate(("left", "right"))}
        elif sensor["id"] == "uwb":
            sensor["tags"] = {str(number[a]): a for a in agents}
    for sink in doc["sinks"]:
        if sink["plugin"] == "live_view":
            sink["port"] = 0
        elif sink["plugin"] == "mavlink_out":
            sink["url"] = f"udpout:127.0.0.1:{gcs_port}"
    return doc


def run_links(scenario: Path, minutes: float, seed: int, gcs_port: int) -> dict:
    """The ten firefighters played over loopback links into the live pipeline (module doc)."""
    import subprocess
    import threading

    from firenav_framework.building.geojson_format import write_geojson
    from firenav_framework.pipeline import load_pipeline_text
    from firenav_framework.runner import Runner
    from firenav_framework.simulator import load_scenario, simulate
    from firenav_framework.transports import clock
    from bench_fieldkit_load import free_port

    sc = load_scenario(scenario)
    agents = [a.id for a in sc.model.agents]
    ports = {"can": free_port(), "mav": free_port(), "lines": free_port()}
    m: dict = {"newest": None, "lat": [], "lat_pose": [], "at": [], "t0": None, "poses": 0,
               "sent": None, "flushed": 0}

    def frames() -> int:
        return sum(runner.stats.counts.get(c, {}).get("frames", 0)
                   for c in ("can", "mav", "lines"))

    def tap(stream: str, msg) -> None:
        if stream in ("can.raw", "mav.raw", "lines.raw"):
            m["newest"] = msg.t if m["newest"] is None else max(m["newest"], msg.t)
        elif stream == "team.pose" and m["newest"] is not None:
            if m["sent"] is not None and frames() >= m["sent"]:
                m["flushed"] += 1       # every frame taken, the links quiet: the stream's end
                return
            now = clock.now()
            m["t0"] = msg.t if m["t0"] is None else m["t0"]
            m["poses"] += 1
            m["lat"].append(now - m["newest"])
            m["lat_pose"].append(now - msg.t)
            m["at"].append(msg.t - m["t0"])

    with tempfile.TemporaryDirectory(prefix="bench-team-links-") as out:
        plan = Path(out) / "plan.geojson"
        write_geojson(simulate(sc, seed, duration_s=1.0).building, plan)
        doc = live_pipeline(plan, agents, ports["can"], ports["mav"], ports["lines"], gcs_port)
        runner = Runner(load_pipeline_text(yaml.safe_dump(doc), base_dir=LIVE.parent),
                        output_dir=Path(out) / "run")
        runner.bus.taps.append(tap)
        box: dict = {}
        thread = threading.Thread(target=lambda: box.setdefault("result", runner.run()),
                                  daemon=True)
        ru0 = resource.getrusage(resource.RUSAGE_SELF)
        thread.start()
        while not all(getattr(runner.components.get(c), "link", None) is not None
                      for c in ("can", "mav", "lines")):
            time.sleep(0.05)
        play = [sys.executable, "-m", "firenav_framework", "play", str(scenario),
                "--seed", str(seed), "--duration", str(60.0 * minutes), "--speed", "1",
                "--can", "udp_multicast:239.74.163.2", "--can-option", f"port={ports['can']}",
                "--mavlink", f"udpout:127.0.0.1:{ports['mav']}",
                "--mavlink-agents", ",".join(a for a in agents if a not in CAN_AGENTS),
                "--lines", f"udp:127.0.0.1:{ports['lines']}"]
        w0 = time.monotonic()
        player = subprocess.run(play, capture_output=True, text=True, cwd=ROOT)
        if player.returncode:
            runner.stop()
            thread.join(60)
            raise SystemExit(f"firenav play failed:\n{player.stderr[-2000:]}")
        sent = [ln for ln in player.stderr.splitlines() if "] sent " in ln]
        counts = re.match(r".*sent (\d+) CAN frames, (\d+) MAVLink packets, (\d+) lines",
                          sent[-1] if sent else "")
        if counts is None:
            raise SystemExit(f"firenav play did not say what it sent:\n{player.stderr[-2000:]}")
        m["sent"] = sum(int(n) for n in counts.groups())
        last, calm = frames(), time.monotonic()
        while time.monotonic() - calm < 3.0:            # until the links stay quiet for 3 s
            time.sleep(0.2)
            if frames() != last:
                last, calm = frames(), time.monotonic()
        runner.stop()
        thread.join(120)
        wall = time.monotonic() - w0
        ru1 = resource.getrusage(resource.RUSAGE_SELF)
        result = box["result"]
        bp = runner.backpressure
    return {"wall_s": wall, "cpu_s": ru1.ru_utime + ru1.ru_stime - ru0.ru_utime - ru0.ru_stime,
            "poses": m["poses"], "agents": len(result.tracks.get("team.pose", {})),
            "faults": len(result.faults), "frames": last, "sent": sent[-1].removeprefix("[play] "),
            "flushed": m["flushed"],
            "degrade_steps": bp.steps if bp is not None else 0,
            "lat": _percentiles(m["lat"]), "lat_pose": _percentiles(m["lat_pose"]),
            "worst_10s": _worst_per_window(m["at"], m["lat"], 10.0)}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--minutes", type=float, default=4.0, help="simulated minutes of the incident")
    ap.add_argument("--seed", type=int, default=100)
    ap.add_argument("--skip-realtime", action="store_true")
    ap.add_argument("--links", action="store_true", help="over the field kit's links, "
                    "played by firenav play in another process (module doc)")
    a = ap.parse_args(argv)
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as gcs, \
            tempfile.TemporaryDirectory(prefix="bench-team-ten-") as tmp:
        gcs.bind(("127.0.0.1", 0))                          # the ground station's port
        scenario = Path(tmp) / "incident_ten.yaml"
        scenario.write_text(yaml.safe_dump(ten_firefighters()))
        print(f"incident with 10 firefighters, {a.minutes:g} simulated min, seed {a.seed}, "
              f"{os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f} before")
        if a.links:
            r = run_links(scenario, a.minutes, a.seed, gcs.getsockname()[1])
            lat, lp = r["lat"], r["lat_pose"]
            print(f"over the links: {r['sent']}; the pipeline took {r['frames']} frames in "
                  f"{r['wall_s']:.0f} s wall, {r['cpu_s']:.0f} s CPU "
                  f"({100 * r['cpu_s'] / r['wall_s']:.0f} % of a core); {r['poses']} fused "
                  f"poses of {r['agents']} firefighters, {r['faults']} faults, "
                  f"{r['degrade_steps']} backpressure steps ({r['flushed']} poses after the last "
                  "frame, at the stream's end, not counted below)")
            print(f"  team.pose latency behind the links p50 / p99 / max: {lat[0]:.0f} / "
                  f"{lat[1]:.0f} / {lat[2]:.0f} ms (goal p99 < 250 ms)")
            print(f"  from the pose's own time: {lp[0]:.0f} / {lp[1]:.0f} / {lp[2]:.0f} ms")
            print(f"  worst latency per 10 s window [ms]: {r['worst_10s']}")
            print(f"  load average now {os.getloadavg()[0]:.1f}")
            return 0
        spec = pipeline(scenario, a.minutes, gcs.getsockname()[1], a.seed)
        fast = run(spec, realtime=False)
        print(f"as fast as possible: {fast['sim_s']:.0f} s simulated in {fast['wall_s']:.0f} s "
              f"wall, {fast['cpu_s']:.0f} s CPU: real-time factor {fast['sim_s'] / fast['wall_s']:.2f}"
              f" (per CPU second {fast['sim_s'] / fast['cpu_s']:.2f}); {fast['poses']} fused poses "
              f"of {fast['agents']} firefighters, {fast['faults']} faults; load average now "
              f"{os.getloadavg()[0]:.1f}", flush=True)
        if not a.skip_realtime:
            live = run(spec, realtime=True)
            lat, lp = live["lat"], live["lat_pose"]
            print(f"paced to the wall clock: {live['sim_s']:.0f} s simulated in "
                  f"{live['wall_s']:.0f} s wall, {live['cpu_s']:.0f} s CPU ({100 * live['cpu_s'] / live['wall_s']:.0f} % of a core); "
                  f"{live['poses']} fused poses, {live['faults']} faults")
            print(f"  team.pose latency behind the devices p50 / p99 / max: {lat[0]:.0f} / "
                  f"{lat[1]:.0f} / {lat[2]:.0f} ms (goal p99 < 250 ms)")
            print(f"  from the pose's own time (stride detection + waiting for the methods): "
                  f"{lp[0]:.0f} / {lp[1]:.0f} / {lp[2]:.0f} ms")
            print(f"  worst latency per 10 s window [ms]: {live['worst_10s']}")
            print(f"  load average now {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
