"""50 web clients on 30 firefighters' tracks of 20 000 points each never hold up the pipeline.

The pipeline thread keeps handing poses and ticks to the live_view sink (50 times an
incident's rate) while 50 clients, in another process as browsers would be, load the
whole state (~19 MB each) and follow the updates. The figure is the sink's own
instrumentation (:class:`firenav_framework.liveview.feed.WaitMeter`): how many messages
held the pipeline in the sink longer than 50 ms (wall time while the process ran; time
the machine gave other programs is not the sink's), never a stopwatch of the test.
The measured phase runs with the start-up heap frozen, as the runner runs a pipeline
(:func:`firenav_framework.runner.frozen_heap`): unfrozen, the interpreter's full
collections in the test suite's process (~200 000 objects, ~120 ms each) would hold
every thread, whichever sink is measured.
"""
from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from firenav_framework.messages import PoseEstimate, Tick
from firenav_framework.runner import frozen_heap
from firenav_framework.sinks.live_view import LiveViewSink
from firenav_framework.testing import make_component

AGENTS, POINTS, CLIENTS = 30, 20_000, 50
CLIENTS_SCRIPT = Path(__file__).with_name("load_clients.py")
COV = np.diag([0.3, 0.3, 0.1, 0.01])


def test_fifty_clients_never_hold_up_the_pipeline(tmp_path):
    sink, _, stats = make_component(LiveViewSink, {"port": 0, "push_period": 0.25},
                                    output_dir=tmp_path)
    sink.start()
    try:
        # the history: 20 000 points per firefighter, handed to the feed as the sink does
        t0 = 1_764_600_000.0
        for k in range(POINTS):
            for a in range(AGENTS):
                sink.feed.put(("pose", f"ff{a + 1:02d}", t0 + 0.5 * k,
                               (round(0.01 * k, 3), round(1.5 * a, 3), 0.0, 0, 0)))
            if k % 2000 == 1999:
                sink.feed.publish()
        sink.feed.publish()
        sink.meter.reset()
        port = sink.server.httpd.server_address[1]
        clients = subprocess.Popen([sys.executable, str(CLIENTS_SCRIPT), str(port),
                                    str(CLIENTS), "3"], stdout=subprocess.PIPE, text=True)
        with frozen_heap():   # as the runner runs a pipeline (see frozen_heap)
            t, k = t0 + 0.5 * POINTS, 0
            while clients.poll() is None and k < 60_000:  # bounded: 10 min at 10 ms a round
                t += 0.02
                for a in range(AGENTS):
                    sink.handle("pf.pose", PoseEstimate(
                        t=t, agent=f"ff{a + 1:02d}", position=np.array([0.01 * k, 1.5 * a, 0.0]),
                        heading=0.0, cov=COV, floor=0, protection_radius=1.2))
                sink.handle("ticks", Tick(t=t, period=1.0))
                k += 1
                time.sleep(0.01)
        out, _ = clients.communicate(timeout=60)
        waits = sink.waits()
    finally:
        sink.finish()
    report = json.loads(out)
    print(f"\nlive view under {CLIENTS} clients x {AGENTS} firefighters x {POINTS} points: "
          f"{waits}; full state {report['clients'][0]['full_bytes'] / 1e6:.1f} MB per client")
    errors = [c for c in report["clients"] if c["kind"] == "error"]
    assert not errors, errors
    assert all(c.get("complete", True) for c in report["clients"])
    assert len(report["points"]) == AGENTS
    assert min(report["points"].values()) >= POINTS  # the whole history, plus new points
    assert all(c["events_after"] > 0 for c in report["clients"] if c["kind"] == "events")
    assert waits["messages"] >= 31 * 10  # the pipeline kept going while they loaded
    assert waits["over_bound"] == 0, waits
    assert stats.counts.get(sink.ctx.id, {}).get("waits_over_bound", 0) == 0
