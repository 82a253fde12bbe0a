"""The ``firenav`` command line. Each subcommand lives in its own module here.

Exit codes: 0 success, 1 the run finished but something failed (e.g. a fault),
2 bad input (pipeline, file or arguments), 130 interrupted.
"""
from __future__ import annotations

import argparse
import importlib
import logging
import os
import pkgutil
import sys

from ..yaml_locations import ConfigError


def _command_modules() -> list[str]:
    """Every module of this package: each defines ``add_parser(subparsers)``."""
    return sorted(m.name for m in pkgutil.iter_modules(__path__) if not m.name.startswith("_"))


#: What the exit codes mean (``firenav --help`` prints this; README.md says the same).
EXIT_CODES = """exit codes:
  0    success
  1    the command finished but something failed: a plugin faulted (or its watchdog
       fired) in a run or replay, a run got no data at all, `map check` found errors
  2    bad input: pipeline, file or arguments (a located message says what)
  130  interrupted before the command could finish (a run stopped by Ctrl-C or
       SIGTERM ends cleanly instead: outputs flushed, summary written, 0 or 1)"""


class UsageError(Exception):
    """A problem with the command line or the files it names (exit code 2)."""


def print_warnings(spec) -> None:
    """The located warnings of a validated pipeline (``PipelineSpec.warnings``), on stderr."""
    for w in spec.warnings:
        print(f"warning: {w}", file=sys.stderr)


def _named_command(argv: list[str]) -> str | None:
    """The command module ``argv`` names (its first word that is not an option), if any."""
    words = [a for a in argv if not a.startswith("-")]
    if not words or any(a in ("-h", "--help") for a in argv[:argv.index(words[0])]):
        return None
    return words[0].replace("-", "_") if words[0].replace("-", "_") in _command_modules() else None


def build_parser(argv: list[str] | None = None) -> argparse.ArgumentParser:
    """The parser of every command, or of only the command ``argv`` names (each command
    module imports what it needs, so ``firenav run`` does not pay for ``firenav play``)."""
    parser = argparse.ArgumentParser(
        prog="firenav", description="Locate firefighters inside buildings: run, check "
        "and evaluate sensor-fusion pipelines.", epilog=EXIT_CODES,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("-v", "--verbose", action="count", default=0,
                        help="more log output (-vv for debug)")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    named = None if argv is None else _named_command(argv)
    for name in [named] if named else _command_modules():
        importlib.import_module(f"{__name__}.{name}").add_parser(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    parser = build_parser(argv)
    args = parser.parse_args(argv)
    logging.basicConfig(level=(logging.WARNING, logging.INFO, logging.DEBUG)[min(args.verbose, 2)],
                        format="%(levelname)s %(name)s: %(message)s")
    try:
        return int(args.func(args) or 0)
    except ConfigError as exc:
        for p in exc.problems:
            print(f"error: {p}", file=sys.stderr)
        return 2
    except UsageError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # output piped into e.g. `head`, which stopped reading
        sys.stdout = open(os.devnull, "w")
        return 0
