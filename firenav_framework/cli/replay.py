"""``firenav replay LOGDIR-or-FILE --pipeline P``: a live pipeline on its recorded logs.

Every live source of the pipeline (``can_bus``, ``mavlink``, ``serial_lines``,
``udp_lines``, ...) is replaced by a ``recording`` source with the same id that reads
what it recorded, ``LOGDIR/<id>/`` (the layout the live sources write under
``<output>/raw/``). Everything downstream (sensors, estimators, sinks) is unchanged,
and since the recorded frames are the very frames the live run saw, the tracks are
identical to the live run's (see docs/field-kit.md for the conditions). A single
FILE replaces the only live source. ``--realtime`` paces the replay to the recorded
timing (``--speed`` times faster).
"""
from __future__ import annotations

import argparse
import copy
import sys
from pathlib import Path

from ..pipeline import apply_overrides, validate_document
from ..registry import default_registry
from ..summary import format_summary
from ..transports.live_source import LiveSource
from ..transports.recorders import log_files
from ..yaml_locations import load
from . import UsageError, print_warnings
from .run import execute, exit_code

#: Suffixes of the logs the live sources write (first file of a rotated set is used).
LOG_SUFFIXES = (".log", ".asc", ".blf", ".trc", ".tlog", ".lines")


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("replay", help="replay recorded field logs through a live pipeline")
    p.add_argument("logs", type=Path, help="folder of recordings (<output>/raw) or one log file")
    p.add_argument("--pipeline", required=True, help="the live pipeline that recorded them")
    p.add_argument("--output", type=Path, metavar="DIR",
                   help="folder for the sinks' files (default: out/<pipeline name>-replay)")
    p.add_argument("--realtime", action="store_true", help="pace to the recorded timing")
    p.add_argument("--speed", type=float, default=1.0, help="with --realtime: this many "
                   "times faster than recorded")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a pipeline value (as for `firenav run`)")
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    p.set_defaults(func=replay)


def first_log(folder: Path) -> Path | None:
    """The first file of the recording in ``folder`` (readers continue through rotations)."""
    files = log_files(folder, LOG_SUFFIXES) if folder.is_dir() else []
    return files[0] if files else None


def replay_document(pipeline: str, logs: Path):
    """The pipeline document with each live source swapped for a recording source."""
    doc = load(pipeline)
    doc.data = copy.deepcopy(doc.data)
    reg = default_registry()
    sources = (doc.data or {}).get("sources") or []
    live = []
    for i, item in enumerate(sources):
        info = reg.get("source", item.get("plugin", "")) if isinstance(item, dict) else None
        if info is not None and issubclass(info.cls, LiveSource):
            live.append((i, item.get("id", item["plugin"])))
    if not live:
        raise UsageError(f"{pipeline}: no live source to replay (it has no can_bus, mavlink, "
                         "serial_lines or udp_lines source)")
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


def replay(args: argparse.Namespace) -> int:
    doc = replay_document(args.pipeline, args.logs)
    done = apply_overrides(doc, list(args.overrides)) if args.overrides else {}
    spec = validate_document(doc, overrides=done)
    print_warnings(spec)
    out = args.output or Path("out") / f"{spec.name}-replay"
    result = execute(spec, out, realtime=args.realtime, speed=args.speed, quiet=args.quiet)
    print(format_summary(result))
    print(f"\nOutput written to {out}/", file=sys.stdout)
    return exit_code(result)
