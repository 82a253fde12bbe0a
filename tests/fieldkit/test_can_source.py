"""CAN through python-can: virtual bus in-process, udp_multicast across processes,
slcan over pyserial's loop://; recording to native logs and exact replay of them."""
from __future__ import annotations

import subprocess
import sys
import uuid

import can
import pytest

from firenav_framework.sources.can_bus import CanBusSource
from firenav_framework.sources.readers import ReadOptions, find_reader
from firenav_framework.transports.can_link import CanLink
from firenav_framework.transports.recorders import log_files

from .conftest import frame_fields, free_port, wait_for

FRAMES = [(0x100 + i % 7, bytes([i % 256, (i * 7) % 256, 0xAB])) for i in range(300)]


def _read_back(path):
    counts: dict[str, int] = {}
    opts = ReadOptions(count=lambda what, n=1: counts.__setitem__(what, counts.get(what, 0) + n))
    return [m for _, m in find_reader(path)(path, opts)], counts


def _send_and_wait(sender: can.BusABC, src, frames: list[tuple[int, bytes]], *,
                   error_frame: bool = False) -> None:
    """Send ``frames`` (id, data) on ``sender``, then an error frame if asked, and wait
    until the running source ``src`` has received as many frames."""
    for arb, data in frames:
        sender.send(can.Message(arbitration_id=arb, data=data, is_extended_id=False))
    if error_frame:
        sender.send(can.Message(is_error_frame=True))
    wait_for(lambda: len(src.frames()) >= len(frames), what="frames")


def test_virtual_bus_frames_recorded_and_replayed_identically(running, tmp_path):
    channel = f"test-{uuid.uuid4().hex}"
    src = running(CanBusSource, {"interface": "virtual", "channel": channel, "device": "can0",
                                 "rotate_mb": 0.004}, tmp_path, cid="can")
    sender = can.Bus(interface="virtual", channel=channel)
    try:
        wait_for(lambda: src.source.link.bus is not None, what="bus open")
        _send_and_wait(sender, src, FRAMES, error_frame=True)
    finally:
        sender.shutdown()
    src.stop()
    live = src.frames()
    assert [(f.channel, f.data) for f in live] == FRAMES
    assert all(f.transport == "can" and f.device == "can0" and f.t == f.t_recv for f in live)
    assert [f.t for f in live] == sorted({f.t for f in live}), "receive times strictly increase"
    assert src.counts()["decode_errors"] == 1  # the error frame: counted, recorded, not passed
    files = log_files(tmp_path / "raw" / "can", (".log",))
    assert len(files) > 1, "4 KiB rotation should have split the recording"
    replayed, counts = _read_back(files[0])
    assert [frame_fields(f) for f in replayed] == [frame_fields(f) for f in live]
    assert counts == {"can_error_frames": 1}


@pytest.mark.parametrize("suffix", [".asc", ".blf"])
def test_other_python_can_formats_replay_the_same_frames(running, tmp_path, suffix):
    channel = f"test-{uuid.uuid4().hex}"
    src = running(CanBusSource, {"interface": "virtual", "channel": channel,
                                 "record_format": suffix}, tmp_path, cid="can")
    sender = can.Bus(interface="virtual", channel=channel)
    try:
        wait_for(lambda: src.source.link.bus is not None, what="bus open")
        _send_and_wait(sender, src, FRAMES[:50])
    finally:
        sender.shutdown()
    src.stop()
    live = src.frames()
    replayed, _ = _read_back(log_files(tmp_path / "raw" / "can", (suffix,))[0])
    assert [(f.channel, f.data) for f in replayed] == [(f.channel, f.data) for f in live]
    if suffix == ".blf":  # exact to the microsecond the live source used
        assert [f.t for f in replayed] == [f.t for f in live]
    else:  # ASC keeps its start time to 1 ms: one constant shift; its relative times
        # are printed to 1 us from a float difference of UNIX times, which may round
        # either way (float64 resolves 0.24 us there)
        shift = [round((r.t - f.t) * 1e6) for r, f in zip(replayed, live)]
        assert max(shift) - min(shift) <= 1 and -1000 <= min(shift) and max(shift) <= 1


SENDER = r"""
import sys, time, can
port, n = int(sys.argv[1]), int(sys.argv[2])
bus = can.Bus(interface="udp_multicast", channel="239.74.163.2", port=port)
time.sleep(0.5)
for rep in range(40):                     # until the parent says stop (stdin closes)
    for i in range(n):
        bus.send(can.Message(arbitration_id=0x200 + i, data=bytes([i, rep % 256]),
                             is_extended_id=False))
    print(rep, flush=True)
    if sys.stdin.readline() == "":
        break
bus.shutdown()
"""


def test_udp_multicast_across_processes(running, tmp_path):
    port = free_port()
    try:
        probe = can.Bus(interface="udp_multicast", channel="239.74.163.2", port=port)
        probe.shutdown()
    except can.CanInitializationError as exc:
        pytest.skip(f"IP multicast unavailable on this machine: {exc}")
    src = running(CanBusSource, {"interface": "udp_multicast", "channel": "239.74.163.2",
                                 "options": {"port": port}, "device": "mc0"}, tmp_path, cid="can")
    proc = subprocess.Popen([sys.executable, "-c", SENDER, str(port), "20"],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        # keep sending rounds until one arrived whole (the first may precede our join)
        while True:
            assert proc.stdout.readline() != "", "sender ended before frames arrived"
            got = [(f.channel, f.data[0]) for f in src.frames()]
            if sum(1 for c, _ in got if c == 0x213) >= 1 and len(got) >= 20:
                break
            proc.stdin.write("more\n")
            proc.stdin.flush()
            wait_for(lambda: len(src.frames()) > len(got), timeout=10, what="next round")
    finally:
        proc.stdin.close()
        proc.wait(30)
    src.stop()
    frames = src.frames()
    assert {f.channel for f in frames} == set(range(0x200, 0x214))
    assert all(f.device == "mc0" for f in frames)


def test_slcan_over_pyserial_loopback():
    link = CanLink("slcan", "loop://", device="slcan0")
    link.open()
    try:
        for arb, data in FRAMES[:20]:
            link.bus.send(can.Message(arbitration_id=arb, data=data, is_extended_id=False))
        got = []
        for _ in range(100):
            got += link.read(0.05)
            if len(got) >= 20:
                break
    finally:
        link.close()
    frames = [link.to_frame(t, m) for t, m in got]
    assert [(f.channel, f.data) for f in frames] == FRAMES[:20]
    assert {f.device for f in frames} == {"slcan0"}


@pytest.mark.parametrize("suffix", [".asc", ".blf", ".trc"])
def test_a_device_named_with_a_large_number_is_recorded(tmp_path, suffix):
    """Channel numbers come from a name's trailing digits; 'bench-932916' overflowed BLF's
    16-bit field (the live source died on it)."""
    from firenav_framework.transports.recorders import CanRecorder

    rec = CanRecorder(tmp_path, "can", suffix=suffix)
    sent = FRAMES[:20]
    for k, (arb, data) in enumerate(sent):
        t = 1_700_000_000.0 + 0.01 * k
        rec.write(round(t * 1e6), can.Message(timestamp=t, arbitration_id=arb, data=data,
                                              is_extended_id=False, channel="bench-932916"))
    rec.close()
    replayed, _ = _read_back(log_files(tmp_path, (suffix,))[0])
    assert [(f.channel, f.data) for f in replayed] == sent


def test_a_failing_recorder_does_not_stop_the_link(running, tmp_path):
    channel = f"test-{uuid.uuid4().hex}"
    src = running(CanBusSource, {"interface": "virtual", "channel": channel}, tmp_path,
                  cid="can")
    sender = can.Bus(interface="virtual", channel=channel)
    try:
        wait_for(lambda: src.source.link.bus is not None and src.source.recorder is not None,
                 what="bus open")

        def disk_full(t_us, item):
            raise OSError(28, "No space left on device")

        src.source.recorder.write = disk_full
        _send_and_wait(sender, src, FRAMES[:40])
    finally:
        sender.shutdown()
    src.stop()
    assert [(f.channel, f.data) for f in src.frames()] == FRAMES[:40]
    assert src.counts()["frames_not_recorded"] == 40
    (diag,) = src.diagnostics("recording_failed")
    assert "No space left" in diag.text and diag.level == "error"
