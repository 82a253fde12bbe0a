"""``firenav plugins list`` and ``firenav plugins show NAME`` (parameter groups listed
member by member under dotted names, with type, default, unit and meaning)."""
from __future__ import annotations

import argparse
import inspect
import shutil

from ..plugin_docs import format_table, param_rows
from ..registry import default_registry
from . import UsageError


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("plugins", help="list installed plugins or show one's parameters")
    psub = p.add_subparsers(dest="action", metavar="ACTION", required=True)
    ls = psub.add_parser("list", help="every installed plugin by kind")
    ls.set_defaults(func=list_plugins)
    show = psub.add_parser("show", help="a plugin's parameters, inputs and outputs")
    show.add_argument("name")
    show.set_defaults(func=show_plugin)


def list_plugins(args: argparse.Namespace) -> int:
    reg = default_registry()
    for kind, infos in reg.by_kind().items():
        print(f"{kind}s:")
        if not infos:
            print("  (none)")
            continue
        rows = [[i.name, f"{i.package} {i.version}".strip(), i.summary] for i in infos]
        print("\n".join("  " + line for line in
                        format_table(rows, ["name", "package", "summary"]).splitlines()))
        print()
    if reg.errors:
        print("problems while loading plugins:")
        for e in reg.errors:
            print(f"  {e}")
    return 0


def _wrap(rows: list[list[str]]) -> dict[int, int]:
    """Wrap widths of the type and meaning columns so that a row fits the terminal."""
    type_w = min(28, max(len(r[1]) for r in rows))
    fixed = max(len(r[0]) for r in rows) + type_w + max(len(r[2]) for r in rows) \
        + max(len(r[3]) for r in rows) + 8
    return {1: type_w, 4: max(30, shutil.get_terminal_size((120, 24)).columns - fixed)}


def show_plugin(args: argparse.Namespace) -> int:
    reg = default_registry()
    infos = reg.find(args.name)
    if not infos:
        from ..pipeline import _did_you_mean
        raise UsageError(f"no plugin named '{args.name}'{_did_you_mean(args.name, reg.names())}")
    for info in infos:
        cls = info.cls
        print(f"{info.name} ({info.kind}) from {info.package} {info.version}".rstrip())
        doc = inspect.cleandoc(cls.__doc__ or "")
        if doc:
            print("\n" + doc)
        if cls.inputs:
            print("\ninputs: " + ", ".join(t.__name__ for t in cls.inputs))
        outs = {k: v.__name__ for k, v in cls.outputs.items()}
        if outs:
            print("outputs: " + ", ".join(f"{k} ({v})" for k, v in outs.items()))
        if info.kind == "estimator" and cls.accepts:
            print("accepts constraints: " + ", ".join(
                f"{c.__name__} ({c.__module__})" for c in cls.accepts))
        if info.kind == "constraint" and cls.capability is not None:
            print(f"capability: {cls.capability.__name__} ({cls.capability.__module__})")
        rows = [[r.name, r.type, r.default, r.unit, r.meaning] for r in param_rows(cls.Params)]
        print("\nparameters:")
        print(format_table(rows, ["name", "type", "default", "unit", "meaning"],
                           _wrap(rows)) if rows else "  (none)")
        print()
    return 0
