"""Helpers for the field-kit tests: driving a live source in a thread, free ports."""
from __future__ import annotations

import socket
import threading
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from firenav_framework.messages import Diagnostic, Message, RawFrame
from firenav_framework.testing import make_component

#: Generous wait for data on a loaded 2-core machine; tests assert on data only.
WAIT_S = 30.0


def free_port(kind: int = socket.SOCK_DGRAM) -> int:
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_for(cond: Callable[[], bool], timeout: float = WAIT_S, what: str = "condition") -> None:
    end = time.monotonic() + timeout
    while not cond():
        if time.monotonic() > end:
            raise AssertionError(f"timed out after {timeout:g} s waiting for {what}")
        time.sleep(0.02)


def wait_for_frames(runner, sent: dict[str, int], links: dict[str, str],
                    timeout: float) -> None:
    """Until each live source (id -> the player's link name) has counted as many frames as
    the player sent on its link."""
    count = lambda cid: runner.stats.counts.get(cid, {}).get("frames", 0)  # noqa: E731
    wait_for(lambda: all(count(cid) >= sent[link] for cid, link in links.items()),
             timeout=timeout, what=f"all {sent} frames at the sources")


def stop_live(runner, thread, closers: list[Callable[[], object] | None],
              timeout: float) -> None:
    """Stop a live run started on ``thread`` and close the test's ends of its links
    (``None`` for one never opened)."""
    runner.stop()
    thread.join(timeout)
    for close in closers:
        if close is not None:
            close()


class RunningSource:
    """A live source's messages() running in a thread, collected in order."""

    def __init__(self, cls, params: dict, out: Path, cid: str = "link"):
        self.source, _, self.stats = make_component(cls, params, output_dir=out, cid=cid)
        self.items: list[tuple[str, Message]] = []
        self.error: BaseException | None = None
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self) -> None:
        try:
            for item in self.source.messages():
                self.items.append(item)
        except BaseException as exc:  # surfaced by stop()
            self.error = exc

    def frames(self) -> list[RawFrame]:
        return [m for p, m in list(self.items) if p == "raw"]

    def diagnostics(self, code: str | None = None) -> list[Diagnostic]:
        return [m for p, m in list(self.items) if p == "diagnostics"
                and (code is None or m.code == code)]

    def stop(self) -> None:
        self.source.stop()
        self.thread.join(WAIT_S)
        assert not self.thread.is_alive(), "source did not stop"
        if self.error is not None:
            raise self.error

    def counts(self) -> dict:
        return dict(self.stats.counts.get(self.source.ctx.id, {}))


@pytest.fixture
def running():
    started: list[RunningSource] = []

    def start(cls, params: dict, out: Path, cid: str = "link") -> RunningSource:
        rs = RunningSource(cls, params, out, cid)
        started.append(rs)
        return rs

    yield start
    for rs in started:
        rs.source.stop()
        rs.thread.join(5)


def frame_fields(f: RawFrame) -> tuple:
    """Everything a RawFrame carries, for exact comparisons."""
    return (f.t, f.t_recv, f.transport, f.channel, f.data, f.device, f.agent)
