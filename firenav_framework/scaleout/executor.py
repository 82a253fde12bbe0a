"""Executors: run independent tasks serially or on Dask, retry a failure once, lose nothing.

A :class:`Task` is a module-level function and its (small, picklable) arguments; the
function must be a pure function of them (an evaluation run is one of pipeline,
scenario, seed and overrides: docs/scale-out.md says what was checked). An executor
yields one :class:`Outcome` per task in the order tasks finish: its value, or the
error of its last attempt with the traceback. A failed task is tried once more
(``retries``); a task that fails twice is reported, and the others go on.

* :class:`SerialExecutor`: in this process, one task after the other (the default);
* :class:`DaskExecutor`: ``workers=N`` starts a ``distributed.LocalCluster`` of N
  single-threaded worker processes, scheduler, nannies, workers and dashboard all
  listening on loopback only (127.0.0.1, random ports); ``scheduler="tcp://host:8786"`` uses a running cluster (``dask
  scheduler`` + ``dask worker``, dask-jobqueue, Kubernetes). Each attempt is its own
  Dask task (``pure=False``, Dask's own ``retries=0``): the retry is ours, so the
  first error is reported too and the retry works the same on every executor.
"""
from __future__ import annotations

import atexit
import logging
import os
import queue
import re
import time
import traceback
import uuid
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from typing import Any

from .progress import Progress

log = logging.getLogger("firenav.scaleout")

#: How often a failed task is tried again.
RETRIES = 1


class ExecutorError(RuntimeError):
    """An executor cannot be set up (no Dask, no scheduler at the address, ...)."""


class TaskError(Exception):
    """A task raised: ``args`` are (``"Type: message"``, traceback text).

    Workers raise this instead of the original exception, whose class may not
    unpickle on the client (or may lose its message doing so).
    """

    def __init__(self, message: str, detail: str = ""):
        super().__init__(message, detail)

    @property
    def message(self) -> str:
        return self.args[0]

    @property
    def detail(self) -> str:
        return self.args[1]


@dataclass(frozen=True)
class Task:
    """One unit of work: ``fn(*args)``. ``key`` is unique in a job and stable across
    restarts (the journal resumes by it); ``label`` is for people (``"seed 3"``)."""

    key: str
    label: str
    fn: Callable[..., Any]
    args: tuple = ()


@dataclass
class Outcome:
    """What became of a task: its value, or the error of its last attempt."""

    task: Task
    value: Any = None
    error: str | None = None
    detail: str = ""
    attempts: int = 1
    wall_s: float = 0.0

    @property
    def ok(self) -> bool:
        return self.error is None


def guarded_call(fn: Callable[..., Any], *args: Any) -> tuple[Any, float]:
    """``(fn(*args), wall seconds)``; any exception becomes a :class:`TaskError`."""
    t0 = time.perf_counter()
    try:
        value = fn(*args)
    except Exception as exc:  # a task's failure is data: reported, retried, never fatal
        raise TaskError(f"{type(exc).__name__}: {exc}", traceback.format_exc()) from None
    return value, time.perf_counter() - t0


class Executor(ABC):
    """Runs tasks; a context manager that releases its workers on exit."""

    retries: int = RETRIES
    #: Short description for progress lines and reports, e.g. "2 local worker processes".
    description: str = ""

    @abstractmethod
    def run(self, tasks: Iterable[Task], progress: Progress | None = None) -> Iterator[Outcome]:
        """Run ``tasks``; yield their outcomes as they finish (retrying each failure once)."""

    def close(self) -> None:
        """Release workers (nothing to do for the serial executor)."""

    def __enter__(self) -> "Executor":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class SerialExecutor(Executor):
    """In this process, one task after the other: today's behaviour of `firenav evaluate`."""

    description = "serial, in this process"

    def __init__(self, retries: int = RETRIES):
        self.retries = retries

    def run(self, tasks: Iterable[Task], progress: Progress | None = None) -> Iterator[Outcome]:
        progress = progress or Progress()
        progress.running(1)
        for task in tasks:
            attempt = 1
            while True:
                try:
                    value, wall = guarded_call(task.fn, *task.args)
                except TaskError as exc:
                    if attempt <= self.retries:
                        progress.retrying(task, exc.message)
                        attempt += 1
                        continue
                    outcome = Outcome(task, error=exc.message, detail=exc.detail,
                                      attempts=attempt)
                else:
                    outcome = Outcome(task, value=value, attempts=attempt, wall_s=wall)
                break
            progress.finished(outcome)
            yield outcome
        progress.running(0)


def _worker_environment(workers: int) -> dict[str, str]:
    """Environment of local worker processes: one BLAS thread, numba's cores shared out.

    Dask's nanny already sets OMP/MKL/OPENBLAS_NUM_THREADS=1; firenav's runs limit BLAS
    to one thread anyway. ``NUMBA_NUM_THREADS`` splits the cores between the workers so
    that the ICP's parallel loop does not oversubscribe them (its per-candidate
    iterations are independent, so the thread count does not change results).
    """
    cores = os.cpu_count() or 1
    return {"NUMBA_NUM_THREADS": str(max(1, cores // max(1, workers))),
            "FIRENAV_BLAS_THREADS": "1"}


def _firenav_version() -> str:
    from importlib.metadata import PackageNotFoundError, version
    try:
        return version("firenav")
    except PackageNotFoundError:
        return "not installed"


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", text)[:60]


class DaskExecutor(Executor):
    """Tasks on Dask: a new loopback LocalCluster (``workers``) or a cluster (``scheduler``)."""

    def __init__(self, *, workers: int | None = None, scheduler: str | None = None,
                 retries: int = RETRIES, connect_timeout_s: float = 10.0):
        if (workers is None) == (scheduler is None):
            raise ExecutorError("give either a number of local workers or a scheduler address")
        try:
            from distributed import Client, LocalCluster
        except ImportError:  # pragma: no cover - distributed is a dependency
            raise ExecutorError("--workers/--scheduler need Dask's 'distributed' package "
                                "(pip install distributed)") from None
        self.retries = retries
        self.cluster = None
        # Dask logs every connection at INFO; show its messages only as verbosely as ours.
        logging.getLogger("distributed").setLevel(logging.getLogger().getEffectiveLevel())
        if scheduler is not None:
            if "://" not in scheduler:
                raise ExecutorError(f"scheduler address '{scheduler}' needs a protocol, "
                                    "e.g. tcp://host:8786")
            try:
                self.client = Client(scheduler, timeout=connect_timeout_s, set_as_default=False)
            except (OSError, TimeoutError, ValueError) as exc:
                raise ExecutorError(f"cannot reach the Dask scheduler at {scheduler}: "
                                    f"{exc}") from None
            self.description = f"the Dask cluster at {scheduler}"
        else:
            if workers < 1:
                raise ExecutorError("--workers must be at least 1")
            self.cluster = LocalCluster(
                n_workers=workers, threads_per_worker=1, processes=True, host="127.0.0.1",
                scheduler_port=0, dashboard_address="127.0.0.1:0", silence_logs=logging.ERROR,
                env=_worker_environment(workers))
            self.client = Client(self.cluster, set_as_default=False)
            self.description = f"{workers} local worker process{'es' if workers > 1 else ''}"
        self._check_versions()

    def _check_versions(self) -> None:
        """Every worker must run the same firenav as this client (same code, same results)."""
        mine = _firenav_version()
        theirs = self.client.run(_firenav_version)
        wrong = {w: v for w, v in theirs.items() if v != mine}
        if wrong:
            self.close()
            raise ExecutorError("workers run another firenav than this client (" + mine + "): "
                                + ", ".join(f"{w}: {v}" for w, v in sorted(wrong.items())))

    def threads(self) -> int:
        """Worker threads in the cluster now (it may grow or shrink)."""
        return sum(self.client.nthreads().values())

    def _running(self, live: dict) -> int:
        try:
            busy = sum(1 for keys in self.client.processing().values() for k in keys
                       if k in live)
            return min(busy, self.threads())
        except Exception:  # a progress figure is not worth failing a job over
            return 0

    def run(self, tasks: Iterable[Task], progress: Progress | None = None) -> Iterator[Outcome]:
        progress = progress or Progress()
        finished: queue.Queue = queue.Queue()
        live: dict[str, tuple[Task, int, Any]] = {}

        def submit(task: Task, attempt: int) -> None:
            key = f"{_slug(task.key)}-{attempt}-{uuid.uuid4().hex[:8]}"
            fut = self.client.submit(guarded_call, task.fn, *task.args, key=key, pure=False,
                                     retries=0)
            live[fut.key] = (task, attempt, fut)
            fut.add_done_callback(finished.put)

        for task in tasks:
            submit(task, 1)
        next_refresh = 0.0
        try:
            while live:
                now = time.monotonic()
                if now >= next_refresh:
                    progress.running(self._running(live))
                    next_refresh = now + 1.0
                try:
                    fut = finished.get(timeout=1.0)
                except queue.Empty:
                    continue
                if fut.key not in live:
                    continue
                task, attempt, _ = live.pop(fut.key)
                if fut.status == "finished":
                    value, wall = fut.result()
                    outcome = Outcome(task, value=value, attempts=attempt, wall_s=wall)
                else:
                    error, detail = _failure_of(fut)
                    if attempt <= self.retries:
                        progress.retrying(task, error)
                        submit(task, attempt + 1)
                        fut.release()
                        continue
                    outcome = Outcome(task, error=error, detail=detail, attempts=attempt)
                fut.release()
                progress.finished(outcome)
                yield outcome
        finally:
            for _, _, fut in live.values():
                fut.cancel()

    def close(self) -> None:
        try:
            self.client.close()
        finally:
            if self.cluster is not None:
                self.cluster.close()


def _failure_of(fut: Any) -> tuple[str, str]:
    """(message, traceback text) of a Dask future that did not finish."""
    if fut.status == "cancelled":
        return "cancelled: the cluster lost the task", ""
    exc = fut.exception()
    if isinstance(exc, TaskError):
        return exc.message, exc.detail
    tb = fut.traceback()
    detail = "".join(traceback.format_tb(tb)) if tb is not None else ""
    return f"{type(exc).__name__}: {exc}", detail


def make_executor(workers: int | None = None, scheduler: str | None = None) -> Executor:
    """The executor the command line asked for: serial, local workers or a cluster."""
    if workers is not None and scheduler is not None:
        raise ExecutorError("--workers and --scheduler exclude each other: --workers starts "
                            "a local cluster, --scheduler uses a running one")
    if workers is None and scheduler is None:
        return SerialExecutor()
    return DaskExecutor(workers=workers, scheduler=scheduler)


_ENVIRONMENT_EXECUTOR: list[Executor] = []


def executor_from_environment() -> Executor | None:
    """The process's executor from ``FIRENAV_WORKERS`` / ``FIRENAV_SCHEDULER``, if set.

    Lets a script that calls :func:`firenav_framework.evaluation.evaluate` (the
    benchmarks) run on Dask without a flag of its own, as Dask's own
    ``DASK_SCHEDULER_ADDRESS`` does. Started on first use, shared by every later
    call in the process and closed when the process exits.
    """
    workers = os.environ.get("FIRENAV_WORKERS", "").strip()
    scheduler = os.environ.get("FIRENAV_SCHEDULER", "").strip()
    if not workers and not scheduler:
        return None
    if not _ENVIRONMENT_EXECUTOR:
        n = None
        if workers:
            try:
                n = int(workers)
            except ValueError:
                raise ExecutorError(f"FIRENAV_WORKERS='{workers}' is not a number") from None
        executor = make_executor(workers=n, scheduler=scheduler or None)
        _ENVIRONMENT_EXECUTOR.append(executor)
        atexit.register(executor.close)
    return _ENVIRONMENT_EXECUTOR[0]
