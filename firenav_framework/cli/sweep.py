"""``firenav sweep SWEEP.yaml``: a grid or random search, tuned and checked in one command.

    firenav sweep sweeps/pf-sigma.yaml --workers 2 --output out/pf-sigma

Runs every setting of the sweep on the tuning seeds, ranks the settings by the median
of the objective, runs the best ones (and the baseline) on the report seeds, and
writes ``results.jsonl`` (as runs finish), ``results.csv`` (+ ``.parquet`` with pyarrow)
and ``report.md`` under the output folder. Started again with the same folder, it
runs only what is missing (``--restart`` starts over). The file format is in
:mod:`firenav_framework.evaluation.sweep` and docs/scale-out.md. Exit code 1 when a
run failed (after its retry), 130 when interrupted (start it again to resume).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from . import UsageError
from ._executor import add_executor_arguments, open_executor


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("sweep", help="grid or random search over pipelines, scenarios, "
                       "seeds and --set values: tune on tuning seeds, check on report seeds")
    p.add_argument("sweep", type=Path, help="sweep file (YAML)")
    p.add_argument("--output", type=Path, metavar="DIR",
                   help="results folder (default: out/sweep-<name>); an existing one resumes")
    p.add_argument("--restart", action="store_true",
                   help="discard the results already in the folder and run everything")
    p.add_argument("--quiet", action="store_true", help="no progress display")
    add_executor_arguments(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..evaluation.report import _fmt
    from ..evaluation.runs import EvaluationError
    from ..evaluation.sweep import load_sweep, run_sweep
    from ..scaleout.progress import BarProgress, Progress
    if not args.sweep.is_file():
        raise UsageError(f"sweep file '{args.sweep}' not found")
    sweep = load_sweep(args.sweep)
    out = args.output or Path("out") / f"sweep-{sweep.name}"
    journal = out / "results.jsonl"
    if args.restart and journal.exists():
        journal.unlink()
    progress = Progress() if args.quiet else BarProgress()
    with open_executor(args) as executor:
        if not args.quiet:
            print(f"[sweep] {sweep.name}: {len(sweep.settings)} settings x "
                  f"{len(sweep.pipelines)} pipelines, tuning seeds "
                  f"{len(sweep.tuning_seeds)}, report seeds {len(sweep.report_seeds)}, on "
                  f"{executor.description}", file=sys.stderr, flush=True)
        try:
            result = run_sweep(sweep, out, executor=executor, progress=progress)
        except EvaluationError as exc:
            raise UsageError(str(exc)) from None
    print(f"{sweep.name}: {result.runs} runs, {result.failed} failed")
    for i, r in enumerate(result.ranked[:5], 1):
        s = r.objective
        print(f"  {i}. {r.pipeline.label} {r.setting.id} "
              f"{' '.join(f'{k}={v}' for k, v in r.setting.params) or '(as is)'}: "
              f"{sweep.metric} median {_fmt(s.median)}"
              f"{'' if r.eligible else f' (not ranked: {r.failed} failed)'}")
    for path in result.table:
        print(f"table: {path}")
    print(f"report: {result.report}")
    return 1 if result.failed else 0
