"""What the runner gives a component: its identity, publishing, counters, reports, the
building and file paths; and :class:`PerAgent`, the per-firefighter state holder.
"""
from __future__ import annotations

import logging
from collections.abc import Callable, Iterator
from contextvars import ContextVar
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Generic, TypeVar

from ..messages import Diagnostic, Message
from ..timefmt import clock_text

if TYPE_CHECKING:
    from ..stats import RunStats

__all__ = ["Context", "PerAgent", "pipeline_dir", "PIPELINE_DIR", "NoBuilding"]

#: Folder of the pipeline file being validated or run (see :func:`pipeline_dir`).
PIPELINE_DIR: ContextVar[Path | None] = ContextVar("firenav_pipeline_dir", default=None)


def pipeline_dir() -> Path:
    """Folder of the pipeline being validated or run, which relative parameter paths are
    relative to; for code outside a pipeline, the working directory. Class methods such as
    ``output_ports`` use it to find a file named in the parameters before construction."""
    return PIPELINE_DIR.get() or Path.cwd()


class NoBuilding(RuntimeError):
    """``ctx.building`` was asked for in a pipeline that has none."""


S = TypeVar("S")


class PerAgent(Generic[S]):
    """Lazily created state per firefighter, with reset for the restart policy."""

    def __init__(self, factory: Callable[[str], S]):
        self._factory = factory
        self._states: dict[str, S] = {}

    def __getitem__(self, agent: str) -> S:
        state = self._states.get(agent)
        if state is None:
            state = self._states[agent] = self._factory(agent)
        return state

    def __setitem__(self, agent: str, state: S) -> None:
        self._states[agent] = state

    def __contains__(self, agent: str) -> bool:
        return agent in self._states

    def __iter__(self) -> Iterator[str]:
        return iter(sorted(self._states))

    def items(self) -> list[tuple[str, S]]:
        return [(a, self._states[a]) for a in sorted(self._states)]

    def reset(self, agent: str | None = None) -> None:
        if agent is None:
            self._states.clear()
        else:
            self._states.pop(agent, None)


@dataclass
class _Pending:
    """What a rate-limited report has gathered since it was last published."""

    agent: str
    level: str
    text: str
    t: float = 0.0
    n: int = 0
    worst: float = 0.0


class Context:
    """What the runner gives a component: identity, publishing, counters, shared data.

    Reporting, from cheapest to loudest: :meth:`count` (a number in the run summary),
    :meth:`report` (a diagnostic at most every ``every`` seconds of data time per key,
    with the counts in between summed), :meth:`warn_once` (one diagnostic per key for
    the whole run) and :meth:`diagnose` (every call publishes).
    """

    def __init__(self, component_id: str, *, stats: "RunStats",
                 publish: Callable[[str, str, Message], None],
                 base_dir: Path, output_dir: Path | None = None,
                 building_loader: Callable[[], Any] | None = None):
        self.id = component_id
        self.stats = stats
        self._publish = publish
        self.base_dir = base_dir
        self.output_dir = output_dir
        self._building_loader = building_loader
        self.log = logging.getLogger(f"firenav.{component_id}")
        self._once: set[tuple[str, str, str]] = set()
        self._last: dict[tuple[str, str], float] = {}
        self._pending: dict[tuple[str, str], _Pending] = {}

    def publish(self, port: str, msg: Message) -> None:
        """Publish ``msg`` on this component's output ``port``."""
        self._publish(self.id, port, msg)

    def count(self, what: str, n: int = 1) -> None:
        """Count an event (a skipped sample, a bad frame ...) for the run summary."""
        if n:
            self.stats.count(self.id, what, n)

    def diagnose(self, t: float, level: str, code: str, text: str, *, agent: str = "",
                 active: bool = True) -> None:
        """Publish a :class:`Diagnostic` on this component's ``diagnostics`` port."""
        self.publish("diagnostics", Diagnostic(t=t, agent=agent, component=self.id,
                                               level=level, code=code, text=text,
                                               active=active))

    def warn_once(self, t: float, code: str, text: str, *, agent: str = "", key: str = "",
                  level: str = "warning") -> bool:
        """:meth:`diagnose` the first time (``agent``, ``code``, ``key``) is seen; True then."""
        k = (agent, code, key)
        if k in self._once:
            return False
        self._once.add(k)
        self.diagnose(t, level, code, text, agent=agent)
        return True

    def report(self, t: float, code: str, text: str, *, n: int = 1, agent: str = "",
               key: str = "", level: str = "warning", every: float = 10.0,
               worst: float = 0.0) -> None:
        """A rate-limited diagnostic: ``n`` more occurrences of ``code`` for ``key``.

        The first occurrence is published at once; later ones at most every ``every``
        seconds of data time, as "``key``: <n summed> ``text``" (with the largest
        ``worst`` [s] so far). What is still pending is published by :meth:`flush_reports`
        (the runner calls it at the end of the run).
        """
        k = (key, code)
        p = self._pending.setdefault(k, _Pending(agent, level, text))
        p.t, p.n, p.worst = t, p.n + n, max(p.worst, worst)
        last = self._last.get(k)
        if last is None or t - last >= every:
            self._emit(k)

    def flush_reports(self) -> None:
        """Publish every pending :meth:`report`."""
        for k in list(self._pending):
            self._emit(k)

    def _emit(self, k: tuple[str, str]) -> None:
        p = self._pending.pop(k)
        key, code = k
        detail = f" (longest {p.worst:.2f} s)" if p.worst else ""
        since = self._last.get(k)
        window = f" since {clock_text(since)}" if since is not None else ""
        prefix = f"{key}: " if key else ""
        self.diagnose(p.t, p.level, code, f"{prefix}{p.n} {p.text}{detail}{window}",
                      agent=p.agent)
        self._last[k] = p.t

    def resolve(self, path: str | Path) -> Path:
        """A path from the pipeline, relative to the pipeline file's folder."""
        p = Path(path).expanduser()
        return p if p.is_absolute() else (self.base_dir / p)

    @property
    def has_building(self) -> bool:
        """Whether this pipeline has a building (its own or one a source brings)."""
        return self._building_loader is not None

    @property
    def building(self) -> Any:
        """The pipeline's building model (loaded once, shared by all components)."""
        if self._building_loader is None:
            raise NoBuilding(f"{self.id}: this pipeline has no building")
        return self._building_loader()
