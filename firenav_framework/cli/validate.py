"""``firenav validate PIPELINE``: check a pipeline without running anything."""
from __future__ import annotations

import argparse

from ..pipeline import load_pipeline
from ..registry import BUILTIN_DIST
from . import print_warnings


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("validate", help="check a pipeline file without running it")
    p.add_argument("pipeline", help="pipeline YAML file")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a value, e.g. estimators.pf.particles=1000")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    spec = load_pipeline(args.pipeline, args.overrides)
    print_warnings(spec)
    print(f"{args.pipeline}: ok ({len(spec.components)} components)")
    for c in spec.components:
        ins = ", ".join(c.inputs) or "-"
        outs = ", ".join(p for p in c.outputs if p != "diagnostics") or "-"
        attached = f" [on {c.parent}]" if c.parent else ""
        label = c.plugin.name if c.plugin.package == BUILTIN_DIST else \
            f"{c.plugin.name}@{c.plugin.package}"
        print(f"  {c.kind:<10} {c.id:<16} {label:<20} in: {ins}  out: {outs}{attached}")
    return 0
