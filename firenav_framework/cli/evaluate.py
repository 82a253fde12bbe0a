"""``firenav evaluate PIPELINE``: run a pipeline against ground truth over several seeds.

    firenav evaluate pipelines/ins.yaml --scenario orca_test2 --seeds 5 \\
        --baseline pipelines/ins_alone.yaml --json out/orca2.json --report out/orca2

Prints the figures of the pipeline and the baseline side by side; ``--json`` writes
them as a JSON object (keys in docs/scenarios.md), ``--report`` a Markdown page with
plots. A pipeline reading a recording with surveyed checkpoints is evaluated once,
against the checkpoints (``--align`` says how its frame is fitted, if at all).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from . import UsageError


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("evaluate", help="measure a pipeline against ground truth over seeds, "
                       "beside a baseline")
    p.add_argument("pipeline", help="pipeline YAML to evaluate")
    p.add_argument("--scenario", help="scenario for the pipeline's simulator source (file or "
                   "bundled name; default: the pipeline's own)")
    p.add_argument("--seeds", default="1", metavar="N|A-B|A,B,...",
                   help="seeds 0..N-1, a range A-B or a list (default 1: seed 0)")
    p.add_argument("--baseline", metavar="PIPELINE", help="second pipeline run on the same "
                   "seeds and scenario (e.g. INS alone)")
    p.add_argument("--stream", help="evaluated pose stream (default: the last estimator's pose)")
    p.add_argument("--baseline-stream", help="pose stream of the baseline pipeline")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a value of the evaluated pipeline (repeatable)")
    p.add_argument("--baseline-set", dest="baseline_overrides", action="append", default=[],
                   metavar="KEY=VALUE", help="override a value of the baseline pipeline")
    p.add_argument("--truth", dest="truth_mode", default="auto",
                   choices=["auto", "dense", "sparse", "checkpoints"],
                   help="dense truth, sparse truth (checkpoints in the truth stream), the "
                   "scenario's marked checkpoints, or auto (default)")
    p.add_argument("--align", default="none", metavar="none|first:K|all",
                   help="checkpoint evaluation: fit the estimate's frame on the first K "
                   "checkpoints (honest) or all (optimistic); default none")
    p.add_argument("--converge-bound", type=float, default=None, metavar="M",
                   help="error bound [m] of the convergence time (default 2)")
    p.add_argument("--json", type=Path, metavar="FILE", help="write the figures as JSON")
    p.add_argument("--report", type=Path, metavar="DIR", help="write report.md with plots")
    p.add_argument("--keep-runs", type=Path, metavar="DIR", help="keep each run's output "
                   "files (sinks) under DIR")
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    p.set_defaults(func=run)


def parse_seeds(text: str) -> list[int]:
    """``"5"`` -> 0..4; ``"3-7"`` -> 3..7; ``"1,4,9"`` -> those."""
    try:
        if "," in text:
            seeds = [int(s) for s in text.split(",") if s.strip()]
        elif "-" in text.strip().lstrip("-"):
            a, b = text.split("-", 1)
            seeds = list(range(int(a), int(b) + 1))
        else:
            seeds = list(range(int(text)))
    except ValueError:
        raise UsageError(f"--seeds '{text}': give N, A-B or a comma-separated list") from None
    if not seeds or min(seeds) < 0:
        raise UsageError(f"--seeds '{text}': need at least one seed, all >= 0")
    return seeds


def _table(ev) -> str:
    from ..evaluation.report import _LABELS, _fmt
    from ..evaluation.metrics import KEYS
    base = ev.baseline
    width = max(len(v) for v in _LABELS.values())
    lines = [f"{'':<{width}}  {'pipeline':>12}" + (f"  {'baseline':>12}" if base else "")]
    for k in KEYS:
        line = f"{_LABELS[k]:<{width}}  {_fmt(getattr(ev.overall, k)):>12}"
        if base:
            line += f"  {_fmt(getattr(base.overall, k)):>12}"
        lines.append(line)
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    from ..evaluation import EvaluationError, evaluate, write_json
    from ..evaluation.metrics import CONVERGE_BOUND_M
    from ..evaluation.report import write_report
    seeds = parse_seeds(args.seeds)
    bound = CONVERGE_BOUND_M if args.converge_bound is None else args.converge_bound
    if not bound > 0:
        raise UsageError("--converge-bound must be positive")
    for p in [args.pipeline] + ([args.baseline] if args.baseline else []):
        if not Path(p).is_file():
            raise UsageError(f"pipeline '{p}' not found")
    progress = None if args.quiet else (lambda s: print(f"[evaluate] {s}", file=sys.stderr,
                                                          flush=True))
    common = dict(scenario=args.scenario, seeds=seeds, truth_mode=args.truth_mode,
                  align=args.align, bound_m=bound, progress=progress)
    try:
        ev = evaluate(args.pipeline, stream=args.stream, overrides=args.overrides,
                      output_dir=args.keep_runs, **common)
        if args.baseline:
            ev.baseline = evaluate(args.baseline, stream=args.baseline_stream,
                                   overrides=args.baseline_overrides,
                                   output_dir=args.keep_runs and args.keep_runs / "baseline",
                                   **common)
    except EvaluationError as exc:
        raise UsageError(str(exc)) from None
    print(f"{Path(args.pipeline).name} on {ev.scenario or 'recorded data'}, "
          f"{len(ev.runs)} run(s), stream {ev.stream}, truth {ev.truth_mode}")
    print(_table(ev))
    if args.json:
        print(f"JSON: {write_json(ev, args.json)}")
    if args.report:
        print(f"report: {write_report(ev, args.report)}")
    return 0
