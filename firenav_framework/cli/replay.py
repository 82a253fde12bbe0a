"""``firenav replay LOGS... --pipeline P``: a live pipeline on its recorded logs.

Every live source of the pipeline (``can_bus``, ``mavlink``, ``serial_lines``,
``udp_lines``, ...) is replaced by a ``recording`` source with the same id that reads
what it recorded, ``LOGDIR/<id>/`` (the layout the live sources write under
``<output>/raw/``). Everything downstream (sensors, estimators, sinks) is unchanged,
and since the recorded frames are the very frames the live run saw, the tracks are
identical to the live run's (see docs/field-kit.md for the conditions). A single
FILE replaces the only live source. ``--realtime`` paces the replay to the recorded
timing (``--speed`` times faster).

Many incidents (several LOGS, or one folder whose subfolders are recordings: a year
of exercises) are replayed as independent runs on the executor (serial, or Dask with
``--workers``/``--scheduler``, docs/scale-out.md): each writes its sinks' files,
``summary.json`` and ``summary.txt`` under ``OUTPUT/<incident>/``, and
``OUTPUT/incidents.csv`` has one row per incident. An incident whose recordings are
missing or whose replay fails (after one retry) is a row with its error; the others
are replayed all the same (exit code 1).
"""
from __future__ import annotations

import argparse
import copy
import csv
import json
import sys
from pathlib import Path

from ..pipeline import apply_overrides, validate_document
from ..registry import default_registry
from ..summary import format_summary, summary_dict
from ..transports.live_source import LiveSource
from ..transports.recorders import log_files
from ..yaml_locations import load
from . import UsageError, print_warnings
from ._executor import add_executor_arguments, open_executor
from .run import execute, exit_code

#: Suffixes of the logs the live sources write (first file of a rotated set is used).
LOG_SUFFIXES = (".log", ".asc", ".blf", ".trc", ".tlog", ".lines")


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("replay", help="replay recorded field logs through a live pipeline "
                       "(one incident, or many on the executor)")
    p.add_argument("logs", type=Path, nargs="+", help="folder of recordings (<output>/raw) "
                   "or one log file; several, or a folder of such folders: many incidents")
    p.add_argument("--pipeline", required=True, help="the live pipeline that recorded them")
    p.add_argument("--output", type=Path, metavar="DIR",
                   help="folder for the sinks' files (default: out/<pipeline name>-replay); "
                   "with many incidents, one subfolder each and incidents.csv")
    p.add_argument("--realtime", action="store_true", help="pace to the recorded timing "
                   "(one incident only)")
    p.add_argument("--speed", type=float, default=1.0, help="with --realtime: this many "
                   "times faster than recorded")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a pipeline value (as for `firenav run`)")
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    add_executor_arguments(p)
    p.set_defaults(func=replay)


def first_log(folder: Path) -> Path | None:
    """The first file of the recording in ``folder`` (readers continue through rotations)."""
    files = log_files(folder, LOG_SUFFIXES) if folder.is_dir() else []
    return files[0] if files else None


def live_sources(doc) -> list[tuple[int, str]]:
    """(index, id) of the live sources of a pipeline document."""
    reg = default_registry()
    live = []
    for i, item in enumerate((doc.data or {}).get("sources") or []):
        info = reg.get("source", item.get("plugin", "")) if isinstance(item, dict) else None
        if info is not None and issubclass(info.cls, LiveSource):
            live.append((i, item.get("id", item["plugin"])))
    if not live:
        raise UsageError(f"{doc.file}: no live source to replay (it has no can_bus, mavlink, "
                         "serial_lines or udp_lines source)")
    return live


def replay_document(pipeline: str, logs: Path):
    """The pipeline document with each live source swapped for a recording source."""
    doc = load(pipeline)
    doc.data = copy.deepcopy(doc.data)
    sources = (doc.data or {}).get("sources") or []
    live = live_sources(doc)
    if logs.is_file():
        if len(live) > 1:
            raise UsageError(f"{pipeline} has {len(live)} live sources "
                             f"({', '.join(c for _, c in live)}); give the folder of recordings")
        files = {live[0][1]: logs}
    elif logs.is_dir():
        files = {cid: first_log(logs / cid) for _, cid in live}
        missing = [cid for cid, f in files.items() if f is None]
        if missing:
            raise UsageError(f"{logs}: no recording for source(s) {', '.join(missing)} "
                             f"(expected {logs}/<source id>/ with {', '.join(LOG_SUFFIXES)} files)")
    else:
        raise UsageError(f"{logs}: no such file or folder")
    for i, cid in live:
        sources[i] = {"id": cid, "plugin": "recording", "path": str(files[cid].resolve())}
    return doc


def _spec(pipeline: str, logs: Path, overrides: list[str]):
    doc = replay_document(pipeline, logs)
    done = apply_overrides(doc, list(overrides)) if overrides else {}
    return validate_document(doc, overrides=done)


def is_recording(folder: Path, live_ids: list[str]) -> bool:
    """Whether ``folder`` holds a recording of every live source (``<folder>/<id>/``)."""
    return all(first_log(folder / cid) is not None for cid in live_ids)


def incidents(logs: list[Path], pipeline: str) -> list[tuple[str, Path]] | None:
    """(name, path) of each incident, or None when ``logs`` is one incident."""
    if len(logs) == 1:
        one = logs[0]
        if one.is_file() or not one.is_dir():
            return None
        live_ids = [cid for _, cid in live_sources(load(pipeline))]
        if is_recording(one, live_ids):
            return None
        subs = sorted(p for p in one.iterdir() if p.is_dir())
        found = [p for p in subs if is_recording(p, live_ids)]
        if not found:
            return None          # replay_document says what is missing
        logs = subs              # every subfolder is an incident, even an incomplete one
    names: dict[str, int] = {}
    out = []
    for p in logs:
        name = p.stem if p.is_file() else p.name
        names[name] = names.get(name, 0) + 1
        out.append((name if names[name] == 1 else f"{name}-{names[name]}", p))
    return out


def replay_incident(pipeline: str, logs: str, out: str, overrides: tuple[str, ...]) -> dict:
    """Replay one incident into ``out`` (files, summary.json, summary.txt); its table row.

    Runs on any worker: only paths and overrides travel, the worker reads the files.
    """
    from ..runner import Runner
    spec = _spec(pipeline, Path(logs), list(overrides))
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    result = Runner(spec, output_dir=folder).run()
    summary = summary_dict(result)
    (folder / "summary.json").write_text(json.dumps(summary, indent=1) + "\n")
    (folder / "summary.txt").write_text(format_summary(result) + "\n")
    return incident_row(summary)


def incident_row(summary: dict) -> dict:
    """The figures of one replayed incident for the table across incidents."""
    lengths: dict[str, float] = {}
    poses = 0
    for agents in summary["tracks"].values():
        for agent, t in agents.items():
            lengths[agent] = max(lengths.get(agent, 0.0), t["length_m"])
            poses += t["poses"]
    return {"data_s": summary["data_s"], "wall_s": summary["wall_s"],
            "messages": sum(summary["messages"].values()), "agents": len(lengths),
            "poses": poses,
            "track_m": "; ".join(f"{a} {m:.1f}" for a, m in sorted(lengths.items())),
            "bad_input": sum(n for kv in summary["counts"].values() for k, n in kv.items()
                             if k != "faults"),
            "faults": len(summary["faults"])}


COLUMNS = ("incident", "ok", "data_s", "wall_s", "messages", "agents", "poses", "track_m",
           "bad_input", "faults", "error", "output")


def replay_many(args: argparse.Namespace, found: list[tuple[str, Path]]) -> int:
    from ..scaleout import Task
    from ..scaleout.progress import BarProgress, Progress
    if args.realtime:
        raise UsageError("--realtime paces one incident; replay many as fast as possible")
    name = load(args.pipeline).data.get("name") or Path(args.pipeline).stem
    out = args.output or Path("out") / f"{name}-replay"
    pipeline = str(Path(args.pipeline).resolve())
    rows: dict[str, dict] = {}
    tasks = []
    for inc, path in found:
        folder = (out / inc).resolve()
        rows[inc] = {"incident": inc, "output": str(folder)}
        try:
            _spec(pipeline, path, args.overrides)      # recordings there, pipeline valid
        except UsageError as exc:
            rows[inc].update(ok=False, error=str(exc))
            continue
        tasks.append(Task(inc, f"incident {inc}", replay_incident,
                          (pipeline, str(path.resolve()), str(folder), tuple(args.overrides))))
    progress = Progress() if args.quiet else BarProgress()
    with open_executor(args) as executor:
        if not args.quiet:
            print(f"[replay] {len(tasks)} incidents on {executor.description}",
                  file=sys.stderr, flush=True)
        progress.start(len(tasks), "replay")
        try:
            for o in executor.run(tasks, progress):
                rows[o.task.key].update(o.value if o.ok else {}, ok=o.ok, error=o.error or "")
        finally:
            progress.close()
    out.mkdir(parents=True, exist_ok=True)
    table = out / "incidents.csv"
    with table.open("w", newline="", encoding="utf-8") as fh:
        w = csv.DictWriter(fh, fieldnames=COLUMNS, restval="")
        w.writeheader()
        w.writerows(rows[inc] for inc, _ in found)
    show = ("incident", "ok", "data_s", "messages", "agents", "poses", "bad_input", "faults")
    lines = [[str(rows[inc].get(c, "")) for c in show] for inc, _ in found]
    widths = [max(len(c), *(len(r[i]) for r in lines)) for i, c in enumerate(show)]
    for r in [list(show)] + lines:
        print("  ".join(v.ljust(w) for v, w in zip(r, widths)).rstrip())
    failed = [inc for inc, _ in found if not rows[inc].get("ok")]
    for inc in failed:
        print(f"incident {inc} FAILED: {rows[inc]['error']}")
    print(f"\n{len(found)} incidents, {len(failed)} failed; table: {table}")
    return 1 if failed else 0


def replay(args: argparse.Namespace) -> int:
    found = incidents(args.logs, args.pipeline)
    if found is not None:
        return replay_many(args, found)
    spec = _spec(args.pipeline, args.logs[0], args.overrides)
    print_warnings(spec)
    out = args.output or Path("out") / f"{spec.name}-replay"
    result = execute(spec, out, realtime=args.realtime, speed=args.speed, quiet=args.quiet)
    print(format_summary(result))
    print(f"\nOutput written to {out}/", file=sys.stdout)
    return exit_code(result)
