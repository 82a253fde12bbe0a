"""Field-kit load: N firefighters' foot IMUs at R Hz (MAVLink HIGHRES_IMU over UDP
loopback) plus 1 Hz breadcrumb lines (UDP), for M minutes, into a live pipeline.

Reports frames sent vs. received (lost), the latency from a frame's send time to its
publication on the pipeline bus after the timeline (p50, p99; goal p99 < 100 ms), and
CPU use of the field kit (receiving process) and of the device simulator (sender), for
the reorder windows given. The sender writes its wall-clock send time into
HIGHRES_IMU.time_usec, so latency needs no clock sync (same machine).

    python benchmarks/bench_fieldkit_load.py --minutes 10            # the full benchmark
    python benchmarks/bench_fieldkit_load.py --minutes 1 --windows 0.05 0.25
"""
from __future__ import annotations

import argparse
import multiprocessing as mp
import os
import resource
import socket
import struct
import tempfile
import threading
import time
from pathlib import Path

import numpy as np


def sender(port_mav: int, port_lines: int, n: int, rate: float, seconds: float, q) -> None:
    os.environ["MAVLINK20"] = "1"
    from pymavlink.dialects.v20 import common as ml
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    mavs = [ml.MAVLink(None, srcSystem=i + 1, srcComponent=1) for i in range(n)]
    for m in mavs:
        m.robust_parsing = True
    dt, sent, crumbs = 1.0 / rate, 0, 0
    t0 = time.monotonic()
    k = 0
    while True:
        due = t0 + k * dt
        now = time.monotonic()
        if now - t0 >= seconds:
            break
        if due > now:
            time.sleep(due - now)
        us = time.time_ns() // 1000
        for i, m in enumerate(mavs):
            pkt = m.highres_imu_encode(us, 0.1, 0.0, -9.81, 0.0, 0.01, 0.0, 0, 0, 0, 0, 0, 0, 0,
                                       0x3F, id=0).pack(m)
            sock.sendto(pkt, ("127.0.0.1", port_mav))
            sent += 1
        if k % int(rate) == 0:
            for i in range(n):
                sock.sendto(b"DROP ff%d bc%d %d\n" % (i + 1, k, us), ("127.0.0.1", port_lines))
                crumbs += 1
        k += 1
    ru = resource.getrusage(resource.RUSAGE_SELF)
    q.put({"imu": sent, "lines": crumbs, "cpu_s": ru.ru_utime + ru.ru_stime,
           "wall_s": time.monotonic() - t0})


PIPELINE = """
name: load
timeline: {{reorder_window: {window}}}
sources:
  - {{id: mav, plugin: mavlink, url: "udpin:127.0.0.1:{pm}", heartbeat_s: 0, record_dir: {rec}}}
  - {{id: lines, plugin: udp_lines, bind: "127.0.0.1:{pl}", record_dir: {rec}}}
"""


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def run(window: float, n: int, rate: float, seconds: float) -> dict:
    from firenav_framework.pipeline import load_pipeline_text
    from firenav_framework.runner import Runner

    rec = Path(tempfile.mkdtemp(prefix="fieldkit-load-"))
    pm, pl = free_port(), free_port()
    spec = load_pipeline_text(PIPELINE.format(window=window, pm=pm, pl=pl, rec=rec))
    latencies: list[float] = []
    counts = {"mav.raw": 0, "lines.raw": 0}

    class Measured(Runner):
        def build(self) -> None:
            super().build()

            def tap(stream, msg):
                if stream in counts:
                    counts[stream] += 1
                if stream == "mav.raw" and msg.channel == 105:
                    sent_us = struct.unpack_from("<Q", msg.data, 10)[0]
                    latencies.append(time.time() - sent_us * 1e-6)
            self.bus.taps.append(tap)

    runner = Measured(spec, output_dir=rec)
    th = threading.Thread(target=runner.run, daemon=True)
    ru0 = resource.getrusage(resource.RUSAGE_SELF)
    w0 = time.monotonic()
    th.start()
    time.sleep(1.0)
    q = mp.Queue()
    proc = mp.Process(target=sender, args=(pm, pl, n, rate, seconds, q))
    proc.start()
    sent = q.get()
    proc.join()
    deadline = time.monotonic() + 30
    while (counts["mav.raw"] < sent["imu"] or counts["lines.raw"] < sent["lines"]) \
            and time.monotonic() < deadline:
        time.sleep(0.2)
    runner.stop()
    th.join(60)
    ru1 = resource.getrusage(resource.RUSAGE_SELF)
    wall = time.monotonic() - w0
    lat = np.array(latencies) * 1e3
    return {"window": window, "sent": sent, "received_imu": counts["mav.raw"],
            "received_lines": counts["lines.raw"],
            "lost": sent["imu"] + sent["lines"] - counts["mav.raw"] - counts["lines.raw"],
            "p50_ms": float(np.percentile(lat, 50)) if lat.size else float("nan"),
            "p99_ms": float(np.percentile(lat, 99)) if lat.size else float("nan"),
            "max_ms": float(lat.max()) if lat.size else float("nan"),
            "cpu_kit": (ru1.ru_utime + ru1.ru_stime - ru0.ru_utime - ru0.ru_stime) / wall,
            "cpu_sender": sent["cpu_s"] / sent["wall_s"],
            "recorded_mb": sum(p.stat().st_size for p in rec.rglob("*") if p.is_file()) / 2**20}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--firefighters", type=int, default=30)
    ap.add_argument("--rate", type=float, default=200.0, help="IMU rate per firefighter [Hz]")
    ap.add_argument("--minutes", type=float, default=10.0)
    ap.add_argument("--windows", type=float, nargs="+", default=[0.05, 0.25],
                    help="timeline reorder windows to compare [s]")
    a = ap.parse_args()
    print(f"{a.firefighters} firefighters x {a.rate:g} Hz HIGHRES_IMU over UDP + 1 Hz "
          f"breadcrumb lines, {a.minutes:g} min, {os.cpu_count()} cores")
    print(f"{'window':>7} {'sent':>9} {'received':>9} {'lost':>5} {'p50 ms':>7} {'p99 ms':>7} "
          f"{'max ms':>7} {'CPU kit':>8} {'CPU devs':>8} {'log MiB':>8}")
    for w in a.windows:
        r = run(w, a.firefighters, a.rate, a.minutes * 60)
        sent = r["sent"]["imu"] + r["sent"]["lines"]
        print(f"{w:>7.2f} {sent:>9d} {r['received_imu'] + r['received_lines']:>9d} "
              f"{r['lost']:>5d} {r['p50_ms']:>7.1f} {r['p99_ms']:>7.1f} {r['max_ms']:>7.1f} "
              f"{100 * r['cpu_kit']:>7.0f}% {100 * r['cpu_sender']:>7.0f}% "
              f"{r['recorded_mb']:>8.1f}", flush=True)
    print("latency = frame send -> published on the pipeline bus after the timeline "
          "(decode + INS come on top); CPU in % of one core")


if __name__ == "__main__":
    main()
