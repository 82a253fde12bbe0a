"""Link health from frame times; crash safety and rotation of the raw recorders."""
from __future__ import annotations

import os
import signal
import subprocess
import sys

import can

from firenav_framework.sources.readers import ReadOptions, find_reader
from firenav_framework.transports.health import LinkMonitor
from firenav_framework.transports.recorders import log_files


def _feed(mon, keys, t0, t1, dt=0.01):
    out = []
    n = round((t1 - t0) / dt)
    for i in range(n):
        t = t0 + i * dt
        for k in keys:
            mon.frame(k, t)
        out += mon.check(t)
    return out


def test_silence_names_the_firefighter_and_clears_when_heard_again():
    mon = LinkMonitor("can", silent_after=2.0, report_every=0,
                      agents={"can0/0x11?": "ff1", "can0/0x12?": "ff2"})
    diags = _feed(mon, ["can0/0x110", "can0/0x120"], 0.0, 10.0)
    assert diags == []
    diags = _feed(mon, ["can0/0x120"], 10.0, 15.0)     # ff1's device unplugged at 10 s
    silent = [d for d in diags if d.code == "device_silent"]
    assert len(silent) == 1 and silent[0].agent == "ff1" and silent[0].active
    assert 2.0 <= silent[0].t - 9.99 <= 2.0 + 0.011   # raised at the first check after 2 s
    diags = _feed(mon, ["can0/0x110", "can0/0x120"], 15.0, 16.0)   # plugged back
    back = [d for d in diags if d.code == "device_silent"]
    assert len(back) == 1 and back[0].agent == "ff1" and not back[0].active
    assert mon.devices["can0/0x120"].silent is False
    assert abs(mon.devices["can0/0x120"].rate_hz - 100.0) < 1.0


def test_short_pause_is_a_gap_and_the_report_lists_errors():
    mon = LinkMonitor("mav", silent_after=2.0, report_every=5.0)
    _feed(mon, ["sys1/comp1/HIGHRES_IMU/0"], 0.0, 3.0)
    mon.decode_error("bad_data", 3)
    diags = _feed(mon, ["sys1/comp1/HIGHRES_IMU/0"], 3.5, 6.0)   # 0.5 s pause at 100 Hz
    assert [d.code for d in diags if d.code != "link_health"] == ["link_gap"]
    report = [d for d in diags if d.code == "link_health"]
    assert report and "1 gaps" in report[-1].text and "bad_data: 3 decode errors" in report[-1].text


WRITER = r"""
import sys, time, can
from pathlib import Path
from firenav_framework.transports.recorders import CanRecorder
rec = CanRecorder(Path(sys.argv[1]), "can", suffix=sys.argv[2], rotate_bytes=20_000, flush_s=0.05)
t_us = 1_700_000_000_000_000
for i in range(10**9):
    msg = can.Message(timestamp=(t_us + i) / 1e6, arbitration_id=0x100, data=i.to_bytes(8, "little"),
                      is_extended_id=False, channel="can0")
    rec.write(t_us + i, msg)
    if i % 50 == 0:
        print(i, time.monotonic(), flush=True)
    time.sleep(0.0005)
"""


def _kill_mid_write(tmp_path, suffix):
    proc = subprocess.Popen([sys.executable, "-c", WRITER, str(tmp_path), suffix],
                            stdout=subprocess.PIPE, text=True)
    reports = []
    while len(reports) < 60:
        line = proc.stdout.readline()
        assert line, "writer died"
        reports.append(tuple(float(x) for x in line.split()))
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    last_i, last_t = reports[-1]
    # every frame written at least flush_s before the last reported write is on disk
    safe = max(i for i, t in reports if t <= last_t - 0.05)
    return int(safe), int(last_i)


def test_kill_9_loses_at_most_the_last_flush_interval(tmp_path):
    safe, last = _kill_mid_write(tmp_path, ".log")
    files = log_files(tmp_path, (".log",))
    assert len(files) > 1, "rotation by size"
    counts = {}
    reader = find_reader(files[0])(files[0], ReadOptions(
        count=lambda w, n=1: counts.__setitem__(w, counts.get(w, 0) + n)))
    got = [int.from_bytes(f.data, "little") for _, f in reader]
    assert got == list(range(len(got))), "in order, none missing, across rotated files"
    assert len(got) > safe


def test_killed_blf_recording_stays_readable(tmp_path):
    safe, _ = _kill_mid_write(tmp_path, ".blf")
    got = []
    for path in log_files(tmp_path, (".blf",)):
        try:
            got += [int.from_bytes(m.data, "little") for m in can.LogReader(str(path))]
        except Exception:
            pass
    assert got[:safe + 1] == list(range(safe + 1))


def test_asc_recording_keeps_the_absolute_start_time_to_the_millisecond(tmp_path):
    """A start 38 ms past the second: python-can alone would write ``.38`` (read as 380 ms)."""
    from firenav_framework.transports.recorders import CanRecorder

    t0 = 1_700_000_000.038881
    rec = CanRecorder(tmp_path, "can", suffix=".asc")
    for k in range(3):
        t = t0 + 0.01 * k
        rec.write(round(t * 1e6), can.Message(timestamp=t, arbitration_id=0x100 + k,
                                              data=bytes([k]), is_extended_id=False))
    rec.close()
    (path,) = log_files(tmp_path, (".asc",))
    frames = [m for _, m in find_reader(path)(path, ReadOptions())]
    assert [f.data for f in frames] == [bytes([0]), bytes([1]), bytes([2])]
    for k, f in enumerate(frames):  # the header keeps whole milliseconds
        assert abs(f.t - (t0 + 0.01 * k)) < 1e-3
