"""``firenav map``: check, draw, convert and list building plans.

PLAN is a plan file (native .geojson, Aamks .json, .dxf) or the name of a bundled plan.
``map check`` exits 1 when the plan has errors (warnings alone exit 0) and 2 when the
file cannot be read at all.
"""
from __future__ import annotations

import argparse
from pathlib import Path

from . import UsageError


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("map", help="check, draw and convert building plans",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    cmds = p.add_subparsers(dest="map_command", metavar="ACTION", required=True)

    def plan_args(q: argparse.ArgumentParser) -> None:
        q.add_argument("plan", help="plan file (.geojson, Aamks .json, .dxf) or bundled plan name")
        q.add_argument("--layers", metavar="YAML", help="DXF layer map (default: a "
                       "<plan>.layers.yaml sidecar, else the built-in table)")

    c = cmds.add_parser("check", help="report concrete problems (with locations) in a plan")
    plan_args(c)
    c.set_defaults(func=run_check)

    s = cmds.add_parser("show", help="write a PNG of every floor")
    plan_args(s)
    s.add_argument("--out", default=".", metavar="DIR", help="output folder (default: .)")
    s.add_argument("--patterns", action="store_true",
                   help="overlay the search patterns extracted from the plan")
    s.add_argument("--dpi", type=int, default=150, help="image resolution (default 150)")
    s.set_defaults(func=run_show)

    v = cmds.add_parser("convert", help="write a plan in the native GeoJSON format")
    plan_args(v)
    v.add_argument("output", help="output .geojson file")
    v.set_defaults(func=run_convert)

    ls = cmds.add_parser("list", help="list the bundled plans")
    ls.set_defaults(func=run_list)


def _load(args: argparse.Namespace):
    from ..building import BuildingError, bundled_plan, bundled_plans, load_building

    path = Path(args.plan)
    if not path.exists() and args.plan in bundled_plans():
        path = bundled_plan(args.plan)
    try:
        return load_building(path, args.layers)
    except BuildingError as exc:
        raise UsageError(str(exc)) from None


def run_check(args: argparse.Namespace) -> int:
    from ..building.check import check_building

    building = _load(args)
    for note in building.notes:
        print(f"note: {note}")
    problems = check_building(building)
    for p in problems:
        print(p)
    errors = sum(p.severity == "error" for p in problems)
    warnings = len(problems) - errors
    floors = len(building.floors)
    walls = sum(len(f.walls) for f in building.floors)
    doors = sum(len(f.doors) for f in building.floors)
    print(f"{args.plan}: {floors} floor(s), {walls} wall segments, {doors} doors: "
          f"{errors} error(s), {warnings} warning(s)")
    return 1 if errors else 0


def run_show(args: argparse.Namespace) -> int:
    from ..building.plot import save_floor_images

    building = _load(args)
    patterns = None
    if args.patterns:
        try:
            from ..building.search_patterns import extract_search_patterns
        except ImportError as exc:
            raise UsageError("--patterns needs firenav_framework.building.search_patterns, "
                             f"which is not available here ({exc})") from None
        patterns = extract_search_patterns(building)
    for path in save_floor_images(building, args.out, patterns=patterns, dpi=args.dpi):
        print(path)
    return 0


def run_convert(args: argparse.Namespace) -> int:
    from ..building.geojson_format import write_geojson

    building = _load(args)
    out = Path(args.output)
    if out.suffix.lower() != ".geojson":
        raise UsageError(f"{out}: the native format is written to a .geojson file")
    write_geojson(building, out)
    for note in building.notes:
        print(f"note: {note}")
    print(out)
    return 0


def run_list(args: argparse.Namespace) -> int:
    from ..building import bundled_plan, bundled_plans, load_building

    for name in bundled_plans():
        b = load_building(bundled_plan(name))
        area = sum(f.outline.area for f in b.floors)
        print(f"{name:<14} {len(b.floors)} floor(s), {area:7.1f} m^2, "
              f"{sum(len(f.rooms) for f in b.floors):3d} rooms, {len(b.doors):3d} doors  "
              f"{bundled_plan(name)}")
    return 0
