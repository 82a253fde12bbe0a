"""The ``--workers`` / ``--scheduler`` options that `evaluate`, `sweep` and `replay` share."""
from __future__ import annotations

import argparse

from ..scaleout import Executor, ExecutorError, make_executor
from . import UsageError


def add_executor_arguments(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("scale-out (docs/scale-out.md)")
    x = g.add_mutually_exclusive_group()
    x.add_argument("--workers", type=int, metavar="N", help="run the runs on a local Dask "
                   "cluster of N worker processes (loopback only); default: serial")
    x.add_argument("--scheduler", metavar="ADDRESS", help="run them on a running Dask "
                   "cluster, e.g. tcp://host:8786")


def open_executor(args: argparse.Namespace) -> Executor:
    """The executor the options ask for (serial without either); bad options exit 2."""
    try:
        return make_executor(workers=args.workers, scheduler=args.scheduler)
    except ExecutorError as exc:
        raise UsageError(str(exc)) from None
