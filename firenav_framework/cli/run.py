"""``firenav run PIPELINE``: run a pipeline (replay, paced, or live) and summarise it."""
from __future__ import annotations

import argparse
import contextlib
import json
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any, TextIO

from ..pipeline import PipelineSpec, load_pipeline
from ..registry import default_registry
from ..runner import PipelineBuildError, Runner, RunResult
from ..sinks.track_plot import background_rendering
from ..summary import format_summary, summary_dict
from ..yaml_locations import load
from . import UsageError, print_warnings


def add_run_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("pipeline", help="pipeline YAML file")
    p.add_argument("--input", metavar="PATH",
                   help="recorded file for the pipeline's file source (sets its input parameter)")
    p.add_argument("--output", metavar="DIR", type=Path,
                   help="folder for the sinks' files (default: out/<pipeline name>)")
    p.add_argument("--realtime", action="store_true",
                   help="pace recorded data to the wall clock instead of as fast as possible")
    p.add_argument("--speed", type=float, default=1.0,
                   help="with --realtime: play this many times faster than real time")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a pipeline value, e.g. estimators.pf.particles=1000 "
                   "(items by id or index); repeatable")
    p.add_argument("--workers", type=int, default=0, metavar="N",
                   help="run the per-firefighter work of estimators that allow it on N "
                   "worker threads (0: all on the pipeline thread; same results either way)")
    p.add_argument("--quiet", action="store_true", help="no progress lines")


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("run", help="run a pipeline")
    add_run_arguments(p)
    p.set_defaults(func=run)


def input_override(pipeline: str, path: str) -> str:
    """The ``--set`` expression that points the pipeline's file source at ``path``."""
    doc = load(pipeline)
    reg = default_registry()
    candidates = []
    for i, item in enumerate((doc.data or {}).get("sources") or []):
        info = reg.get("source", item.get("plugin", "")) if isinstance(item, dict) else None
        if info is not None and info.cls.input_param:
            candidates.append((i, item.get("id", item["plugin"]), info.cls.input_param))
    if not candidates:
        raise UsageError(f"{pipeline}: no source in this pipeline reads an --input file")
    if len(candidates) > 1:
        names = ", ".join(f"sources.{c[1]}.{c[2]}" for c in candidates)
        raise UsageError(f"{pipeline}: several sources read files ({names}); "
                         "choose with --set instead of --input")
    if not Path(path).exists():
        raise UsageError(f"--input {path}: no such file")
    i, _, param = candidates[0]
    return f"sources[{i}].{param}={json.dumps(str(Path(path).resolve()))}"


def prepare(args: argparse.Namespace) -> tuple[PipelineSpec, Path]:
    overrides = list(args.overrides)
    if args.input:
        overrides.insert(0, input_override(args.pipeline, args.input))
    spec = load_pipeline(args.pipeline, overrides)
    print_warnings(spec)
    out = args.output or Path("out") / spec.name
    return spec, out


class CompileNotice:
    """Says what numba is compiling while it compiles (a first run, or after an upgrade),
    when nothing else would print for a minute or more: one line when it starts, then one
    per kernel at most every ``every`` seconds, with the count and the time so far."""

    def __init__(self, stream: TextIO, every: float = 2.0):
        self.stream, self.every = stream, every
        self.kernels = 0
        self._depth = 0
        self._t0: float | None = None
        self._next = 0.0

    def on_start(self, event: Any) -> None:
        self._depth += 1
        if self._depth > 1:   # a kernel another one calls: part of that one's compile
            return
        self.kernels += 1
        now = time.monotonic()
        name = getattr(event.data.get("dispatcher"), "__qualname__", "kernel")
        if self._t0 is None:
            self._t0 = now
            self._say("compiling (first run only): numba compiles and caches the array "
                      "kernels, about a minute; later runs start at once")
        if now >= self._next:
            self._next = now + self.every
            self._say(f"compiling {name} ({self.kernels} kernels, {now - self._t0:.0f} s)")

    def on_end(self, event: Any) -> None:
        self._depth -= 1

    def _say(self, text: str) -> None:
        print(f"[firenav] {text}", file=self.stream, flush=True)


@contextlib.contextmanager
def compile_notice(stream: TextIO | None) -> Iterator[CompileNotice | None]:
    """:class:`CompileNotice` on ``stream`` for the duration (None: silent)."""
    if stream is None:
        yield None
        return
    from numba.core import event   # numba is imported here, not by every command

    class Listener(event.Listener):
        def on_start(self, ev: Any) -> None:
            notice.on_start(ev)

        def on_end(self, ev: Any) -> None:
            notice.on_end(ev)

    notice = CompileNotice(stream)
    with event.install_listener("numba:compile", Listener()):
        yield notice


def execute(spec: PipelineSpec, out: Path, *, realtime: bool = False, speed: float = 1.0,
            quiet: bool = False, workers: int = 0) -> RunResult:
    """Run a validated pipeline, writing its files and summary.json under ``out``."""
    if speed <= 0:
        raise UsageError("--speed must be positive")
    if workers < 0:
        raise UsageError("--workers must be 0 or more")
    out.mkdir(parents=True, exist_ok=True)
    runner = Runner(spec, output_dir=out, realtime=realtime, speed=speed,
                    progress=None if quiet else sys.stderr, workers=workers, hard_exit=True)
    if not quiet:   # at once: a first run may then compile for a minute
        print(f"[firenav] running {spec.name} ({len(spec.components)} components), output "
              f"to {out}/", file=sys.stderr, flush=True)
    try:
        # SIGTERM and Ctrl-C end the run cleanly (see watchdog.py)
        with compile_notice(None if quiet else sys.stderr), background_rendering():
            result = runner.run()
    except PipelineBuildError as exc:
        raise UsageError(str(exc)) from None
    (out / "summary.json").write_text(json.dumps(summary_dict(result), indent=1) + "\n")
    return result


def exit_code(result: RunResult) -> int:
    """0 for a clean run; 1 (with the reason on stderr) when a plugin faulted or when no
    source delivered any data (the run produced nothing)."""
    problems = []
    if result.faults:
        problems.append(f"{len(result.faults)} plugin fault(s), see 'Plugin faults' above")
    if result.t_first is None:
        problems.append("no source delivered any data")
    for p in problems:
        print(f"error: {p}", file=sys.stderr)
    return 1 if problems else 0


def run(args: argparse.Namespace) -> int:
    spec, out = prepare(args)
    result = execute(spec, out, realtime=args.realtime, speed=args.speed, quiet=args.quiet,
                     workers=args.workers)
    print(format_summary(result))
    print(f"\nOutput written to {out}/")
    return exit_code(result)
