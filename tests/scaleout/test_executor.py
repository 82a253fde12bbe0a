"""Executors: every task's outcome, a failure retried once and reported, loopback only."""
from __future__ import annotations

import os
from pathlib import Path

import pytest

from firenav_framework.scaleout import (ExecutorError, Journal, Progress, SerialExecutor, Task,
                                        make_executor)


def square(x: int) -> int:
    return x * x


def fails_once(marker: str, x: int) -> int:
    """Fails the first time it is called for ``marker`` (a file), then succeeds."""
    m = Path(marker)
    if not m.exists():
        m.write_text("called")
        raise RuntimeError(f"transient failure for {x}")
    return x + 100


def always_fails(x: int) -> int:
    raise ValueError(f"input {x} is bad")


def pid() -> int:
    return os.getpid()


def _tasks(tmp_path: Path) -> list[Task]:
    tasks = [Task(f"sq{i}", f"seed {i}", square, (i,)) for i in range(6)]
    tasks.append(Task("flaky", "seed 7", fails_once, (str(tmp_path / "marker"), 7)))
    tasks.append(Task("bad", "seed 8", always_fails, (8,)))
    return tasks


class Recorder(Progress):
    def __init__(self):
        super().__init__()
        self.notes: list[str] = []

    def note(self, text: str) -> None:
        self.notes.append(text)


@pytest.mark.parametrize("kind", ["serial", "cluster"])
def test_every_outcome_arrives_a_failure_is_retried_once_and_reported(kind, cluster, tmp_path):
    executor = SerialExecutor() if kind == "serial" else cluster
    progress = Recorder()
    progress.start(8)
    got = {o.task.key: o for o in executor.run(_tasks(tmp_path), progress)}
    assert sorted(got) == sorted(t.key for t in _tasks(tmp_path))
    for i in range(6):
        assert got[f"sq{i}"].ok and got[f"sq{i}"].value == i * i and got[f"sq{i}"].attempts == 1
    assert got["flaky"].ok and got["flaky"].value == 107 and got["flaky"].attempts == 2
    bad = got["bad"]
    assert not bad.ok and bad.attempts == 2 and bad.value is None
    assert bad.error == "ValueError: input 8 is bad"
    assert "always_fails" in bad.detail          # the worker's traceback comes back
    assert progress.done == 8 and progress.failed == 1 and progress.retried == 2
    assert any("seed 8 FAILED after 2 attempts: ValueError: input 8 is bad" in n
               for n in progress.notes)
    assert any("seed 7 failed (RuntimeError: transient failure for 7); trying once more" in n
               for n in progress.notes)


def test_local_cluster_is_worker_processes_on_loopback_only(cluster):
    info = cluster.client.scheduler_info()
    assert info["address"].startswith("tcp://127.0.0.1:")
    assert len(info["workers"]) == 2
    assert all(addr.startswith("tcp://127.0.0.1:") for addr in info["workers"])
    assert all(w["nthreads"] == 1 for w in info["workers"].values())
    pids = set(cluster.client.run(pid).values())
    assert len(pids) == 2 and os.getpid() not in pids
    assert "127.0.0.1" in cluster.cluster.dashboard_link


def test_executor_choice_and_its_errors():
    assert isinstance(make_executor(), SerialExecutor)
    with pytest.raises(ExecutorError, match="exclude each other"):
        make_executor(workers=2, scheduler="tcp://127.0.0.1:1")
    with pytest.raises(ExecutorError, match="needs a protocol"):
        make_executor(scheduler="127.0.0.1:8786")
    with pytest.raises(ExecutorError, match="at least 1"):
        make_executor(workers=0)
    # nothing listens on port 1: a clear error, in bounded time
    with pytest.raises(ExecutorError, match="cannot reach the Dask scheduler"):
        from firenav_framework.scaleout import DaskExecutor
        DaskExecutor(scheduler="tcp://127.0.0.1:1", connect_timeout_s=2)


def test_journal_keeps_results_and_survives_a_cut_last_line(tmp_path):
    path = tmp_path / "results.jsonl"
    j = Journal(path)
    j.append({"key": "a", "ok": True, "x": 1})
    j.append({"key": "b", "ok": False, "error": "boom"})
    with path.open("a") as fh:
        fh.write('{"key": "c", "ok": tr')           # the job was killed mid-write
    again = Journal(path)
    assert again.damaged == 1
    assert again.done() == {"a"}                     # b failed: it is run again
    again.append({"key": "c", "ok": True})
    third = Journal(path)
    assert third.damaged == 1 and third.done() == {"a", "c"}
