"""``firenav evaluate PIPELINE``: run a pipeline against ground truth over several seeds.

    firenav evaluate pipelines/ins.yaml --scenario orca_test2 --seeds report \\
        --baseline pipelines/ins_alone.yaml --json out/orca2.json --report out/orca2 \\
        --workers 2

Prints the figures of the pipeline and the baseline side by side, each pooled over all
runs and as its spread over runs (min / median / max, 95 % interval of the median);
``--json`` writes them as a JSON object (keys in docs/scenarios.md), ``--report`` a
Markdown page with plots. Seeds are a count, a range, a list or a named set of the
held-out protocol (``tuning``, ``report``, ``fresh-report``: evaluation/seeds.py).
``--workers N`` / ``--scheduler ADDRESS`` run the runs on Dask (docs/scale-out.md);
the figures are the same as serially. A run that fails is retried once; if it fails
again it is reported with its seed and error, the others are scored, and the exit
code is 1. A pipeline reading a recording with surveyed checkpoints is evaluated
once, against the checkpoints (``--align`` says how its frame is fitted, if at all).

A recording with truth, as ``firenav run`` reads it::

    firenav evaluate pipelines/foot-ins.yaml --input ../shared/data/indoor-walks/walk_31.mat
    firenav evaluate pipelines/foot-ins.yaml --input imuMeasLeft.csv --truth positionGt.csv

``--input`` points the pipeline's file source at the recording; its own truth is the
reference unless ``--truth FILE`` names another recording to take it from; the
estimate's frame (an INS's own) is fitted on the first 5 m of the truth's path unless
``--align`` says otherwise (dense truth is then taken point by point, as checkpoints).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from . import UsageError
from ._executor import add_executor_arguments, open_executor


#: How a recorded run's estimate is fitted to its truth unless --align says otherwise: a
#: rotation and translation on the first 5 m (an INS knows neither at the start).
RECORDING_ALIGN = "first:5m"


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("evaluate", help="measure a pipeline against ground truth over seeds, "
                       "beside a baseline")
    p.add_argument("pipeline", help="pipeline YAML to evaluate")
    p.add_argument("--input", metavar="PATH", help="recorded file for the pipeline's file "
                   "source (as `firenav run --input`); its truth (or --truth FILE) is the "
                   "reference, and the estimate's frame is fitted on the first 5 m unless "
                   "--align says otherwise")
    p.add_argument("--scenario", help="scenario for the pipeline's simulator source (file or "
                   "bundled name, see `firenav simulate --list`; default: the pipeline's own)")
    p.add_argument("--seeds", default="1", metavar="N|A-B|A,B,...|NAME",
                   help="seeds 0..N-1 (N up to 100: a single seed S is S-S), a range "
                   "A-B, a list, or a named set: tuning "
                   "(100-139, for choosing defaults), report (1000-1029, for reported "
                   "figures), fresh-report (2000-2029); default 1: seed 0")
    p.add_argument("--baseline", metavar="PIPELINE", help="second pipeline run on the same "
                   "seeds and scenario (e.g. INS alone)")
    p.add_argument("--stream", help="evaluated pose stream (default: the last estimator's pose)")
    p.add_argument("--baseline-stream", help="pose stream of the baseline pipeline")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a value of the evaluated pipeline (repeatable)")
    p.add_argument("--baseline-set", dest="baseline_overrides", action="append", default=[],
                   metavar="KEY=VALUE", help="override a value of the baseline pipeline")
    p.add_argument("--truth", dest="truth_mode", default="auto", metavar="MODE|FILE",
                   help="dense truth, sparse truth (checkpoints in the truth stream), the "
                   "scenario's marked checkpoints, auto (default), or a FILE: a recording "
                   "whose truth is the reference (e.g. a dataset file)")
    p.add_argument("--align", default=None, metavar="none|first:K|first:Dm|all",
                   help="fit the estimate's frame on the first K truth points or the first "
                   "D metres (honest) or on all (optimistic); default none (first:5m with "
                   "--input)")
    p.add_argument("--converge-bound", type=float, default=None, metavar="M",
                   help="error bound [m] of the convergence time (default 2)")
    p.add_argument("--json", type=Path, metavar="FILE", help="write the figures as JSON")
    p.add_argument("--report", type=Path, metavar="DIR", help="write report.md with plots")
    p.add_argument("--keep-runs", type=Path, metavar="DIR", help="keep each run's output "
                   "files (sinks) under DIR (a folder the workers can write)")
    p.add_argument("--quiet", action="store_true", help="no progress display")
    add_executor_arguments(p)
    p.set_defaults(func=run)


def parse_seeds(text: str) -> list[int]:
    """The ``--seeds`` value (see :func:`firenav_framework.evaluation.seeds.parse_seeds`)."""
    from ..evaluation.seeds import SeedError, parse_seeds as parse
    try:
        return parse(text)
    except SeedError as exc:
        raise UsageError(f"--{exc}") from None


def format_table(ev) -> str:
    """The figures of ``ev`` (and its baseline) as a fixed-width text table."""
    from ..evaluation.report import figure_header, figure_rows
    rows = [figure_header(ev)] + figure_rows(ev)
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    return "\n".join("  ".join(c.ljust(w) if i == 0 else c.rjust(w)
                               for i, (c, w) in enumerate(zip(r, widths))).rstrip()
                     for r in rows)


def run(args: argparse.Namespace) -> int:
    from ..evaluation import EvaluationError, write_json
    from ..evaluation.metrics import CONVERGE_BOUND_M
    from ..evaluation.report import write_report
    from ..evaluation.runs import TRUTH_MODES, plan_evaluation, run_plans
    from ..evaluation.seeds import describe_seeds
    from ..scaleout.progress import BarProgress, Progress
    seeds = parse_seeds(args.seeds)
    bound = CONVERGE_BOUND_M if args.converge_bound is None else args.converge_bound
    if not bound > 0:
        raise UsageError("--converge-bound must be positive")
    for p in [args.pipeline] + ([args.baseline] if args.baseline else []):
        if not Path(p).is_file():
            raise UsageError(f"pipeline '{p}' not found")
    truth_mode, truth_file = args.truth_mode, None
    if truth_mode not in TRUTH_MODES:
        if not Path(truth_mode).is_file():
            raise UsageError(f"--truth {truth_mode}: neither a truth mode "
                             f"({', '.join(TRUTH_MODES)}) nor a file")
        truth_mode, truth_file = "auto", truth_mode
    align = args.align or (RECORDING_ALIGN if args.input else "none")
    overrides, baseline_overrides = list(args.overrides), list(args.baseline_overrides)
    if args.input:
        from .run import input_override
        overrides.insert(0, input_override(args.pipeline, args.input))
        if args.baseline:
            baseline_overrides.insert(0, input_override(args.baseline, args.input))
    common = dict(scenario=args.scenario, seeds=seeds, truth_mode=truth_mode,
                  align=align, bound_m=bound, truth_file=truth_file)
    try:
        plans = [plan_evaluation(args.pipeline, stream=args.stream, overrides=overrides,
                                 output_dir=args.keep_runs, **common)]
        if args.baseline:
            plans.append(plan_evaluation(
                args.baseline, stream=args.baseline_stream, overrides=baseline_overrides,
                output_dir=args.keep_runs and args.keep_runs / "baseline", **common))
    except EvaluationError as exc:
        raise UsageError(str(exc)) from None
    progress = Progress() if args.quiet else BarProgress()
    with open_executor(args) as executor:
        if not args.quiet:
            print(f"[evaluate] {sum(len(p.runs) for p in plans)} runs on "
                  f"{executor.description}", file=sys.stderr, flush=True)
        try:
            evs = run_plans(plans, executor=executor, progress=progress)
        except EvaluationError as exc:
            raise UsageError(str(exc)) from None
    ev = evs[0]
    if args.baseline:
        ev.baseline = evs[1]
    print(f"{Path(args.pipeline).name} on {ev.scenario or args.input or 'recorded data'}, "
          f"{len(ev.runs)} run(s), seeds {describe_seeds(ev.seeds)}, stream {ev.stream}, "
          f"truth {ev.truth_mode}{f' from {truth_file}' if truth_file else ''}, aligned "
          f"{align}")
    print(format_table(ev))
    failed = [(name, f) for name, e in (("", ev), ("baseline ", ev.baseline)) if e is not None
              for f in e.failed]
    for name, f in failed:
        print(f"{name}seed {f.seed} FAILED after {f.attempts} attempts (not scored): {f.error}")
    if args.json:
        print(f"JSON: {write_json(ev, args.json)}")
    if args.report:
        print(f"report: {write_report(ev, args.report)}")
    return 1 if failed else 0
