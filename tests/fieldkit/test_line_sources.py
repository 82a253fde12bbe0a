"""Serial and UDP line links: framing, overlong lines, unplug/replug, exact replay."""
from __future__ import annotations

import socket
import threading

from hypothesis import given, strategies as st

from firenav_framework.sources.readers import ReadOptions, find_reader
from firenav_framework.sources.serial_lines import SerialLinesSource
from firenav_framework.sources.udp_lines import UdpLinesSource
from firenav_framework.transports.line_links import SerialLineLink
from firenav_framework.transports.recorders import escape_bytes, log_files, unescape_bytes

from .conftest import frame_fields, free_port, wait_for


@given(st.binary(max_size=200))
def test_escaping_round_trips_and_stays_one_line(data):
    text = escape_bytes(data)
    assert b"\n" not in text and b"\r" not in text
    assert unescape_bytes(text) == data


def test_serial_loopback_framing():
    link = SerialLineLink("loop://", device="uwb0", max_line=16)
    link.open()
    try:
        link.write(b"RANGE a1 3.25\r\nRAN")
        got = link.read(0.5)
        link.write(b"GE a2 4.5\n" + b"x" * 40 + b"\nok\n")
        for _ in range(20):
            got += link.read(0.05)
    finally:
        link.close()
    frames = [link.to_frame(t, n) for t, n in got]
    assert [f.data if f else None for f in frames] == [b"RANGE a1 3.25", b"RANGE a2 4.5", None, b"ok"]


class _Device:
    """A serial device behind pyserial's socket:// URL that can be unplugged and replugged."""

    def __init__(self):
        self.server = socket.socket()
        self.server.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self.server.bind(("127.0.0.1", 0))
        self.server.listen(1)
        self.port = self.server.getsockname()[1]
        self.conn = None
        self.accepted = threading.Event()
        threading.Thread(target=self._accept, daemon=True).start()

    def _accept(self):
        self.conn, _ = self.server.accept()
        self.accepted.set()

    def unplug(self):
        self.conn.close()
        self.accepted.clear()
        threading.Thread(target=self._accept, daemon=True).start()

    def close(self):
        if self.conn:
            self.conn.close()
        self.server.close()


def test_serial_device_unplugged_and_back(running, tmp_path):
    dev = _Device()
    src = running(SerialLinesSource, {"url": f"socket://127.0.0.1:{dev.port}", "device": "uwb0",
                                      "reconnect_s": 0.1, "device_agents": {"uwb0": "ff2"}},
                  tmp_path, cid="uwb")
    try:
        assert dev.accepted.wait(30)
        # pyserial discards input while it opens a port: send once the link is open
        wait_for(lambda: src.source.link.port is not None, what="port open")
        dev.conn.sendall(b"".join(b"R %d\n" % i for i in range(10)))
        wait_for(lambda: len(src.frames()) >= 10, what="first lines")
        dev.unplug()
        wait_for(lambda: src.diagnostics("link_down"), what="link_down")
        assert dev.accepted.wait(30), "the source did not reconnect"
        wait_for(lambda: [d for d in src.diagnostics("link_down") if not d.active],
                 what="link back")
        dev.conn.sendall(b"".join(b"R %d\n" % i for i in range(10, 20)))
        wait_for(lambda: len(src.frames()) >= 20, what="lines after replug")
    finally:
        src.stop()
        dev.close()
    assert [f.data for f in src.frames()] == [b"R %d" % i for i in range(20)]
    downs = src.diagnostics("link_down")
    assert [d.active for d in downs] == [True, False], "lost, then back"
    assert src.counts()["link_lost"] == 1
    logs = log_files(tmp_path / "raw" / "uwb", (".lines",))
    replayed = [m for _, m in find_reader(logs[0])(logs[0], ReadOptions())]
    assert [frame_fields(f) for f in replayed] == [frame_fields(f) for f in src.frames()]


def test_udp_lines_per_sender_and_replay(running, tmp_path):
    port = free_port()
    src = running(UdpLinesSource, {"bind": f"127.0.0.1:{port}", "max_line": 64}, tmp_path,
                  cid="udp")
    wait_for(lambda: src.source.link.sock is not None, what="socket bound")
    a, b = socket.socket(socket.AF_INET, socket.SOCK_DGRAM), socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    a.sendto(b"A 1\nA 2\n", ("127.0.0.1", port))
    b.sendto(b"B 1\xff\\", ("127.0.0.1", port))
    a.sendto(b"x" * 100, ("127.0.0.1", port))
    a.sendto(b"A 3", ("127.0.0.1", port))
    wait_for(lambda: len(src.frames()) >= 4, what="lines")
    src.stop()
    pa, pb = f"127.0.0.1:{a.getsockname()[1]}", f"127.0.0.1:{b.getsockname()[1]}"
    a.close(), b.close()
    assert [(f.device, f.data) for f in src.frames()] == [
        (pa, b"A 1"), (pa, b"A 2"), (pb, b"B 1\xff\\"), (pa, b"A 3")]
    assert src.counts()["decode_errors"] == 1
    logs = log_files(tmp_path / "raw" / "udp", (".lines",))
    replayed = [m for _, m in find_reader(logs[0])(logs[0], ReadOptions())]
    assert [frame_fields(f) for f in replayed] == [frame_fields(f) for f in src.frames()]
