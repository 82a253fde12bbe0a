"""Field-kit load: N firefighters' foot IMUs at R Hz (MAVLink HIGHRES_IMU over UDP
loopback) plus 1 Hz breadcrumb lines (UDP), for M minutes, through the live pipeline
of the field kit (mavlink source -> foot_imu -> zupt_ins, every frame recorded).

The device simulator (a separate process) plays the simulated ``indoor_walk`` foot IMU
(200 Hz, z-down) in a loop, each firefighter from another point of the walk, one
HIGHRES_IMU per sample at the sample's due time; device time k / R is due at
``t0 + k / R`` on the wall clock. Reported, per reorder window:

* frames sent, received by the source, IMU samples reaching the INS; lost = sent -
  received (a UDP packet dropped anywhere on the way);
* latency to the **published pose**: for every pose zupt_ins publishes, the wall time
  of publication minus the due time of the sample that made it possible. That sample
  is somewhere in the block foot_imu had just handed over (``frames.block_s`` of samples), so
  two figures bound it: from the block's newest sample (transport, timeline, decoding,
  INS) and from its oldest (plus the wait for the block to fill); p50 / p99, goal p99
  < 100 ms. Also the latency from a frame's due time to its release by the timeline
  (the transport part alone);
* CPU of the field kit (this process) and of the device simulator, in % of one core,
  and how late the sender was (its own lag, which counts in the latency);
* the worst pose latency per 10 s window, and the backpressure's ``degraded`` /
  ``restored`` reports (a firefighter moved to the cheaper mode while the kit was
  behind);
* with ``--replays K``: the recorded logs replayed K times (``firenav replay``'s way: a
  recording source in place of each live source), each replay's tracks compared with
  the others' and with the live run's.

``--busy`` starts a process that keeps one core busy for the whole run (another
program on the field laptop); ``--workers N`` runs the per-firefighter INS on N worker
threads (``Runner(workers=N)``).

    python benchmarks/bench_fieldkit_load.py --minutes 10 --busy     # the issue's run
    python benchmarks/bench_fieldkit_load.py --minutes 1 --blocks 0.02 0.05 0.1
    python benchmarks/bench_fieldkit_load.py --minutes 1 --parsers datagram pymavlink
    python benchmarks/bench_fieldkit_load.py --minutes 0.5 --profile  # where the time goes
"""
from __future__ import annotations

import argparse
import cProfile
import io
import multiprocessing as mp
import os
import pstats
import resource
import socket
import tempfile
import threading
import time
from pathlib import Path

import numpy as np


def walk_samples() -> tuple[float, np.ndarray]:
    """(rate [Hz], (N, 6) accel+gyro in the device's FRD axes) of the simulated walk."""
    from firenav_framework.simulator import load_scenario, simulate
    rec = simulate(load_scenario("indoor_walk"), 0).imu["ff1"]
    return rec.rate_hz, np.hstack((rec.accel, rec.gyro))


def sender(port_mav: int, port_lines: int, n: int, seconds: float, start, q) -> None:
    os.environ["MAVLINK20"] = "1"
    from pymavlink.dialects.v20 import common as ml
    rate, data = walk_samples()
    rows = data.tolist()
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    mavs = [ml.MAVLink(None, srcSystem=i + 1, srcComponent=1) for i in range(n)]
    phase = [i * len(rows) // n for i in range(n)]
    dt = 1.0 / rate
    lags = []
    sent = crumbs = 0
    cpu0 = time.process_time()
    start.wait()
    t0 = time.time() + 0.2
    q.put({"t0": t0})
    k = 0
    while k * dt < seconds:
        due = t0 + k * dt
        now = time.time()
        if due > now:
            time.sleep(due - now)
        lags.append(time.time() - due)
        usec = round(k * dt * 1e6)
        for i, m in enumerate(mavs):
            r = rows[(phase[i] + k) % len(rows)]
            sock.sendto(m.highres_imu_encode(usec, *r, 0, 0, 0, 0, 0, 0, 0, 0x3F, id=0).pack(m),
                        ("127.0.0.1", port_mav))
            sent += 1
        if k % round(rate) == 0:
            for i in range(n):
                sock.sendto(b"DROP ff%d bc%d %d\n" % (i + 1, k, usec), ("127.0.0.1", port_lines))
                crumbs += 1
        k += 1
    lag = np.array(lags) * 1e3
    q.put({"imu": sent, "lines": crumbs, "cpu_s": time.process_time() - cpu0,
           "wall_s": time.time() - t0, "lag_p99_ms": float(np.percentile(lag, 99)),
           "lag_max_ms": float(lag.max())})


PROCESSING = """
sensors:
  - {{id: imu, plugin: foot_imu, input: mav.raw, axes: [x, -y, -z],
     frames: {{block_s: {block}, agent_map: {agents}}}}}
estimators:
  - {{id: ins, plugin: zupt_ins, input: imu.imu, imu: {{sample_rate: 200}}}}
"""
PIPELINE = """
name: load
timeline: {{reorder_window: {window}, late: deliver}}
sources:
  - {{id: mav, plugin: mavlink, url: "udpin:127.0.0.1:{pm}", heartbeat_s: 0, record_dir: raw,
     rotate_mb: {rotate}}}
  - {{id: lines, plugin: udp_lines, bind: "127.0.0.1:{pl}", record_dir: raw}}
""" + PROCESSING
#: The same processing on the recorded MAVLink log (as ``firenav replay`` swaps the sources).
REPLAY = """
name: load-replay
timeline: {{reorder_window: {window}, late: deliver}}
sources:
  - {{id: mav, plugin: recording, path: {log}}}
""" + PROCESSING


def spin(seconds: float) -> None:
    """Keep one core busy for ``seconds`` (the --busy neighbour)."""
    end = time.monotonic() + seconds
    x = 0
    while time.monotonic() < end:
        for _ in range(10000):
            x += 1


def agent_map(n: int) -> str:
    return "{" + ", ".join(f'"sys{i + 1}/*": ff{i + 1}' for i in range(n)) + "}"


def replay(rec: Path, n: int, block: float, window: float, workers: int) -> dict:
    """The INS tracks of the recorded MAVLink log replayed offline (as ``firenav replay``)."""
    from firenav_framework.cli.replay import first_log
    from firenav_framework.pipeline import load_pipeline_text
    from firenav_framework.runner import Runner
    spec = load_pipeline_text(REPLAY.format(window=window, log=first_log(rec / "raw" / "mav"),
                                            block=block, agents=agent_map(n)))
    return Runner(spec, workers=workers).run().tracks.get("ins.pose", {})


def same_tracks(a: dict, b: dict) -> bool:
    """Whether two {agent: Track} maps hold identical poses (times, positions, headings)."""
    return a.keys() == b.keys() and all(
        np.array_equal(a[k].t, b[k].t) and np.array_equal(a[k].position, b[k].position)
        and np.array_equal(a[k].heading, b[k].heading) for k in a)


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _percentiles(values: list[float]) -> tuple[float, float, float]:
    if not values:
        return (float("nan"),) * 3
    a = np.array(values) * 1e3
    return float(np.percentile(a, 50)), float(np.percentile(a, 99)), float(a.max())


def _worst_per_window(at: list[float], lat: list[float], width: float) -> list[float]:
    """The largest latency [ms] in each ``width``-second window of send time."""
    if not at:
        return []
    k = (np.array(at) // width).astype(int)
    worst = np.zeros(k.max() + 1)
    np.maximum.at(worst, k, np.array(lat) * 1e3)
    return worst.round().tolist()


def run(window: float, block: float, n: int, seconds: float, profile: bool,
        parser: str = "datagram", rotate_mb: float = 64.0, workers: int = 0,
        busy: bool = False, replays: int = 0) -> dict:
    from firenav_framework.messages import ImuBlock, PoseEstimate, RawFrame
    from firenav_framework.pipeline import load_pipeline_text
    from firenav_framework.runner import Runner
    from firenav_framework.transports import clock
    from firenav_framework.transports.live_source import LiveSource
    from firenav_framework.transports.mavlink_link import MavlinkLink

    rec = Path(tempfile.mkdtemp(prefix="fieldkit-load-"))
    pm, pl = free_port(), free_port()
    agents = agent_map(n)
    spec = load_pipeline_text(PIPELINE.format(window=window, pm=pm, pl=pl,
                                              block=block, agents=agents, rotate=rotate_mb))
    m: dict = {"t0": None, "offset": {}, "block": {}, "pose_lat": [], "pose_lat_oldest": [],
               "bus_lat": [], "bus_at": [], "pose_at": [], "stopping": False,
               "frames": 0, "lines": 0, "samples": 0, "poses": 0}

    def tap(stream: str, msg) -> None:
        if stream == "mav.raw" and isinstance(msg, RawFrame) and msg.channel == 105:
            m["frames"] += 1
            t_dev = int.from_bytes(msg.data[10:18], "little") * 1e-6
            if m["t0"] is not None:
                m["bus_lat"].append(clock.now() - (m["t0"] + t_dev))
                m["bus_at"].append(t_dev)
            # the sensor's DeviceClock anchors each device at its first sample like this
            m["offset"].setdefault(msg.data[5], msg.t - t_dev)
        elif stream == "lines.raw":
            m["lines"] += 1
        elif stream == "imu.imu" and isinstance(msg, ImuBlock):
            m["samples"] += len(msg)
            m["block"][msg.agent] = (float(msg.time[-1]), float(msg.time[0]))
        elif stream == "ins.pose" and isinstance(msg, PoseEstimate) and m["t0"] is not None \
                and not m["stopping"]:   # not the poses finish() publishes after the run
            m["poses"] += 1
            now, offset = clock.now(), m["offset"][int(msg.agent[2:])]
            newest, oldest = m["block"][msg.agent]
            m["pose_lat"].append(now - (m["t0"] + newest - offset))
            m["pose_at"].append(newest - offset)
            m["pose_lat_oldest"].append(now - (m["t0"] + oldest - offset))

    open_link = MavlinkLink.open
    if parser == "pymavlink":  # the reference: pymavlink's stream parser, as for serial/TCP
        def stream_open(self):
            open_link(self)
            self._udp = False
        MavlinkLink.open = stream_open

    profiles: list[cProfile.Profile] = []
    if profile:  # one profiler per thread: the source threads and the pipeline thread
        original = LiveSource.messages

        def profiled(self):
            prof = cProfile.Profile()
            profiles.append(prof)
            prof.enable()
            try:
                yield from original(self)
            finally:
                prof.disable()
        LiveSource.messages = profiled

    class Measured(Runner):
        def build(self) -> None:
            super().build()
            self.bus.taps.append(tap)

        def run(self):
            if not profile:
                return super().run()
            prof = cProfile.Profile()
            profiles.append(prof)
            prof.enable()
            try:
                return super().run()
            finally:
                prof.disable()

    runner = Measured(spec, output_dir=rec, workers=workers)
    th = threading.Thread(target=runner.run, daemon=True)
    ru0 = resource.getrusage(resource.RUSAGE_SELF)
    w0 = time.monotonic()
    th.start()
    q: mp.Queue = mp.Queue()
    start = mp.Event()
    proc = mp.Process(target=sender, args=(pm, pl, n, seconds, start, q))
    proc.start()
    neighbour = mp.Process(target=spin, args=(seconds + 30,), daemon=True) if busy else None
    if neighbour is not None:
        neighbour.start()
    while not all(getattr(runner.components.get(c), "link", None) is not None
                  for c in ("mav", "lines")):
        time.sleep(0.05)
    time.sleep(0.5)
    start.set()
    m["t0"] = q.get(timeout=120)["t0"]
    sent = q.get(timeout=seconds + 120)
    proc.join()
    deadline = time.monotonic() + 30
    while (m["frames"] < sent["imu"] or m["lines"] < sent["lines"]) and time.monotonic() < deadline:
        time.sleep(0.2)
    m["stopping"] = True
    runner.stop()
    th.join(120)
    ru1 = resource.getrusage(resource.RUSAGE_SELF)
    wall = time.monotonic() - w0
    if neighbour is not None:
        neighbour.terminate()
        neighbour.join()
    MavlinkLink.open = open_link
    if profile:
        LiveSource.messages = original
        out = io.StringIO()
        st = pstats.Stats(profiles[0], stream=out)
        for p in profiles[1:]:
            st.add(p)
        st.sort_stats("tottime").print_stats(25)
        print(out.getvalue())
    counts = runner.stats.counts
    steps = [d for d in runner.diagnostics if d.code in ("degraded", "restored")]
    live_tracks = runner.store.tracks().get("ins.pose", {})
    same = [same_tracks(live_tracks, replay(rec, n, block, window, workers))
            for _ in range(replays)]
    return {"pose_by_10s": _worst_per_window(m["pose_at"], m["pose_lat"], 10.0),
            "degraded": sum(d.code == "degraded" for d in steps),
            "restored": sum(d.code == "restored" for d in steps),
            "degrade_texts": [d.text for d in steps[:3]], "replays_identical": same,
            "wall": wall, "window": window, "block": block, "parser": parser, "sent": sent,
            "received": m["frames"] + m["lines"], "samples": m["samples"], "poses": m["poses"],
            "lost": sent["imu"] + sent["lines"] - m["frames"] - m["lines"],
            "pose": _percentiles(m["pose_lat"]), "pose_oldest": _percentiles(m["pose_lat_oldest"]),
            "bus": _percentiles(m["bus_lat"]),
            "bus_by_10s": _worst_per_window(m["bus_at"], m["bus_lat"], 10.0),
            "files": sorted(p.name for p in rec.rglob("*.tlog")),
            "late": counts.get("timeline", {}).get("late_delivered", 0),
            "cpu_kit": (ru1.ru_utime + ru1.ru_stime - ru0.ru_utime - ru0.ru_stime) / wall,
            "cpu_sender": sent["cpu_s"] / sent["wall_s"],
            "recorded_mb": sum(p.stat().st_size for p in rec.rglob("*") if p.is_file()) / 2**20}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--firefighters", type=int, default=30)
    ap.add_argument("--minutes", type=float, default=10.0)
    ap.add_argument("--windows", type=float, nargs="+", default=[0.05],
                    help="timeline reorder windows to compare [s]")
    ap.add_argument("--blocks", type=float, nargs="+", default=[0.05],
                    help="foot_imu frames.block_s values to compare [s]")
    ap.add_argument("--parsers", nargs="+", default=["datagram"],
                    choices=["datagram", "pymavlink"], help="MAVLink UDP reading: ours (per "
                    "datagram, numba CRC) and/or pymavlink's stream parser (the reference)")
    ap.add_argument("--rotate-mb", type=float, default=64.0, help="log rotation size [MiB]")
    ap.add_argument("--series", action="store_true", help="also print the worst bus latency "
                    "per 10 s of the run (to see when the kit fell behind)")
    ap.add_argument("--profile", action="store_true", help="print where the kit's time goes")
    ap.add_argument("--busy", action="store_true", help="keep one core busy with another "
                    "process for the whole run")
    ap.add_argument("--workers", type=int, default=0, help="worker threads for the "
                    "per-firefighter INS (0: all on the pipeline thread)")
    ap.add_argument("--replays", type=int, default=0, help="replay the recording this many "
                    "times and compare the tracks with the live run's")
    a = ap.parse_args()
    print(f"{a.firefighters} firefighters x 200 Hz HIGHRES_IMU over UDP + 1 Hz breadcrumb "
          f"lines, {a.minutes:g} min, {os.cpu_count()} cores, load average "
          f"{os.getloadavg()[0]:.1f} before the first run; "
          f"{'one core kept busy by another process; ' if a.busy else ''}"
          f"{a.workers} INS worker threads")
    print(f"{'parser':>9} {'window':>6} {'block':>5} {'sent':>8} {'lost':>5} {'samples':>8} "
          f"{'poses':>6} {'pose ms p50/p99 (newest..oldest sample)':>40} {'bus p50/p99':>13} {'late':>5} "
          f"{'CPU kit':>7} {'CPU devs':>8} {'lag p99':>7} {'log MiB':>7}")
    for parser, w, b in [(p, w, b) for p in a.parsers for w in a.windows for b in a.blocks]:
        r = run(w, b, a.firefighters, a.minutes * 60, a.profile, parser, a.rotate_mb,
                a.workers, a.busy, a.replays)
        s = r["sent"]
        new, old, bus = r["pose"], r["pose_oldest"], r["bus"]
        print(f"{parser:>9} {w:>6.2f} {b:>5.2f} {s['imu'] + s['lines']:>8d} {r['lost']:>5d} "
              f"{r['samples']:>8d} {r['poses']:>6d} {new[0]:>7.0f}..{old[0]:<5.0f} / "
              f"{new[1]:>7.0f}..{old[1]:<7.0f}      {bus[0]:>5.0f} /{bus[1]:>5.0f} "
              f"{r['late']:>5d} {100 * r['cpu_kit']:>6.0f}% {100 * r['cpu_sender']:>7.0f}% "
              f"{s['lag_p99_ms']:>5.1f}ms {r['recorded_mb']:>7.1f}", flush=True)
        worst = r["pose_by_10s"]
        print(f"    worst pose latency of a 10 s window: {max(worst, default=float('nan')):.0f} ms"
              f"; backpressure: {r['degraded']} degraded, {r['restored']} restored; kit CPU "
              f"{r['cpu_kit'] * r['wall']:.1f} s in {r['wall']:.1f} s wall; load average now "
              f"{os.getloadavg()[0]:.1f}")
        for text in r["degrade_texts"]:
            print(f"      {text}")
        if r["replays_identical"]:
            print(f"    replays of the recording: tracks identical to the live run's: "
                  f"{r['replays_identical']}")
        if a.series:
            print(f"    worst pose latency per 10 s [ms]: {worst}")
            print(f"    worst bus latency per 10 s [ms]: {r['bus_by_10s']}")
            print(f"    {len(r['files'])} tlog files (a rotation every {a.rotate_mb:g} MiB)")
    print("pose latency: published - due time of the newest..oldest sample of the block that "
          "produced it; bus: frame due -> released by the timeline; CPU in % of one core; "
          "lag: how late the device simulator sent (p99)")


if __name__ == "__main__":
    main()
