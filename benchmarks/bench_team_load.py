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

    python benchmarks/bench_team_load.py --minutes 4
"""
from __future__ import annotations

import argparse
import copy
import json
import os
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


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--minutes", type=float, default=4.0, help="simulated minutes of the incident")
    ap.add_argument("--seed", type=int, default=100)
    ap.add_argument("--skip-realtime", action="store_true")
    a = ap.parse_args(argv)
    gcs = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)   # the ground station's port
    gcs.bind(("127.0.0.1", 0))
    with tempfile.TemporaryDirectory(prefix="bench-team-ten-") as tmp:
        scenario = Path(tmp) / "incident_ten.yaml"
        scenario.write_text(yaml.safe_dump(ten_firefighters()))
        spec = pipeline(scenario, a.minutes, gcs.getsockname()[1], a.seed)
        print(f"incident with 10 firefighters, {a.minutes:g} simulated min, seed {a.seed}, "
              f"{os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f} before")
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
    gcs.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
