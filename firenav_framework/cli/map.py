"""``firenav map``: check, draw, convert, georeference, export and list building plans.

PLAN is a plan file (native .geojson, Aamks .json, .dxf) or the name of a bundled plan.
``map check`` exits 1 when the plan has errors (warnings alone exit 0) and 2 when the
file cannot be read at all.

``map georef`` pins the plan to the Earth: ``--origin LAT,LON[,ALT]`` is the WGS84
position (degrees; ALT the ellipsoidal height [m] of plan z = 0) of plan point ``--at``
(default 0,0), and ``--heading DEG`` the compass bearing (degrees clockwise from true
north) that the plan's +y axis points to; or ``--control X,Y,LAT,LON`` two or more
times (surveyed plan points) for a least-squares fit. A native plan is updated in
place (or written to ``--out``); other formats need ``--out``. Write a negative
latitude as ``--origin=-33.92,18.42``.

``map export`` writes the plan for GIS tools: RFC 7946 GeoJSON (WGS84) when it is
georeferenced, else plan metres with a ``coordinate_frame`` member saying so.
"""
from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

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

    g = cmds.add_parser("georef", help="give a plan its geographic reference (WGS84)")
    plan_args(g)
    g.add_argument("--origin", metavar="LAT,LON[,ALT]", help="WGS84 position of the plan point "
                   "--at (degrees, ellipsoidal height in m)")
    g.add_argument("--at", metavar="X,Y", default="0,0", help="plan point [m] at --origin "
                   "(default 0,0)")
    g.add_argument("--heading", type=float, metavar="DEG", help="compass bearing of the plan's "
                   "+y axis, degrees clockwise from true north")
    g.add_argument("--control", action="append", default=[], metavar="X,Y,LAT,LON",
                   help="a surveyed control point (repeat, at least two): fits origin and heading")
    g.add_argument("--alt", type=float, default=0.0, metavar="M", help="with --control: "
                   "ellipsoidal height [m] of plan z = 0 (default 0)")
    g.add_argument("--max-residual", type=float, default=2.0, metavar="M", help="with "
                   "--control: refuse a fit that leaves a point farther off (default 2 m)")
    g.add_argument("--out", metavar="OUT.geojson", help="write the georeferenced native plan "
                   "here (default: update PLAN in place, native plans only)")
    g.set_defaults(func=run_georef)

    x = cmds.add_parser("export", help="write the plan as GeoJSON for GIS tools (RFC 7946 "
                        "WGS84 when georeferenced)")
    plan_args(x)
    x.add_argument("output", help="output .geojson file")
    x.set_defaults(func=run_export)

    ls = cmds.add_parser("list", help="list the bundled plans")
    ls.set_defaults(func=run_list)


def _plan_path(args: argparse.Namespace) -> Path:
    from ..building import bundled_plan, bundled_plans

    path = Path(args.plan)
    if not path.exists() and args.plan in bundled_plans():
        path = bundled_plan(args.plan)
    return path


def _load(args: argparse.Namespace):
    from ..building import BuildingError, load_building

    try:
        return load_building(_plan_path(args), args.layers)
    except BuildingError as exc:
        raise UsageError(str(exc)) from None


def _numbers(text: str, what: str, counts: tuple[int, ...]) -> list[float]:
    try:
        vals = [float(v) for v in text.split(",")]
    except ValueError:
        vals = []
    if len(vals) not in counts or not all(math.isfinite(v) for v in vals):
        raise UsageError(f"{what} must be {' or '.join(str(c) for c in counts)} numbers "
                         f"separated by commas, got {text!r}")
    return vals


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


def _fit_georef(args: argparse.Namespace):
    """The GeoRef the options ask for, and lines describing how well it fits."""
    from ..building.georef import GeoRef, fit_control_points

    if args.control:
        if args.origin or args.heading is not None:
            raise UsageError("give either --origin and --heading, or --control points")
        pts = np.array([_numbers(c, "--control", (4,)) for c in args.control])
        try:
            fit = fit_control_points(pts[:, :2], pts[:, [3, 2]], alt=args.alt)
        except ValueError as exc:
            raise UsageError(str(exc)) from None
        lines = [f"control point ({x:.2f}, {y:.2f}): {r:.3f} m off"
                 for (x, y), r in zip(pts[:, :2], fit.residuals)]
        lines.append(f"the points are {abs(fit.scale - 1) * 100:.2f} % "
                     f"{'farther apart' if fit.scale > 1 else 'closer'} on the ground than on "
                     "the plan" if abs(fit.scale - 1) > 1e-4 else "plan scale agrees with the points")
        if fit.residuals.max() > args.max_residual:
            raise UsageError("the control points do not fit one turn and shift of the plan: "
                             + "; ".join(lines) + f" (limit {args.max_residual} m; wrong pairing "
                             "or a plan not to scale?)")
        return fit.georef, lines
    if not args.origin or args.heading is None:
        raise UsageError("give --origin LAT,LON[,ALT] and --heading DEG, or two or more "
                         "--control X,Y,LAT,LON")
    lat, lon, *alt = _numbers(args.origin, "--origin", (2, 3))
    x, y = _numbers(args.at, "--at", (2,))
    try:
        return GeoRef.at_point((x, y), lat, lon, bearing=args.heading,
                               alt=alt[0] if alt else 0.0), []
    except ValueError as exc:
        raise UsageError(str(exc)) from None


def run_georef(args: argparse.Namespace) -> int:
    from ..building import BuildingError, bundled_plans
    from ..building.geojson_format import dump_plan, parse_geojson, write_geojson
    from ..building.loader import read_plan_json

    building = _load(args)
    georef, lines = _fit_georef(args)
    src = _plan_path(args)
    native = src.suffix.lower() == ".geojson" and args.plan not in bundled_plans()
    if not args.out and not native:
        raise UsageError(f"{args.plan}: only a native .geojson plan file is updated in "
                         "place; give --out OUT.geojson")
    out = Path(args.out) if args.out else src
    if out.suffix.lower() != ".geojson":
        raise UsageError(f"{out}: the georeferenced plan is written in the native format, "
                         "to a .geojson file")
    g = georef.describe()
    feature = {"type": "Feature", "geometry": {"type": "Point", "coordinates": g["anchor_xy_m"]},
               "properties": {"kind": "georef", "lat": g["lat"], "lon": g["lon"],
                              "alt": g["alt_m"], "bearing_deg": g["bearing_deg"]}}
    if native:
        # Edit the file's own features so everything else in it stays as it was.
        doc = read_plan_json(src)
        doc["features"] = [f for f in doc["features"]
                           if (f.get("properties") or {}).get("kind") != "georef"] + [feature]
        try:
            parse_geojson(doc, where=str(out))
        except BuildingError as exc:
            raise UsageError(str(exc)) from None
        out.write_text(dump_plan(doc), encoding="utf-8")
    else:
        building.georef = georef
        write_geojson(building, out)
    corners = np.array(building.floor(0).outline.bounds).reshape(2, 2)
    (lo_lon, lo_lat, _), (hi_lon, hi_lat, _) = georef.to_wgs84(corners)
    print(f"georef: plan point ({g['anchor_xy_m'][0]:.2f}, {g['anchor_xy_m'][1]:.2f}) at "
          f"lat {g['lat']:.7f}, lon {g['lon']:.7f}, {g['alt_m']:.2f} m; plan +y "
          f"{g['bearing_deg']:.2f} deg clockwise from true north")
    for line in lines:
        print(f"  {line}")
    print(f"floor 0 corners ({corners[0][0]:.1f}, {corners[0][1]:.1f}) -> {lo_lat:.7f}, "
          f"{lo_lon:.7f}; ({corners[1][0]:.1f}, {corners[1][1]:.1f}) -> {hi_lat:.7f}, {hi_lon:.7f}")
    print(out)
    return 0


def run_export(args: argparse.Namespace) -> int:
    from ..building.gis_export import write_gis_geojson

    building = _load(args)
    out = Path(args.output)
    if out.suffix.lower() not in (".geojson", ".json"):
        raise UsageError(f"{out}: GeoJSON is written to a .geojson (or .json) file")
    write_gis_geojson(building, out)
    print(f"{out}: " + ("RFC 7946 GeoJSON, WGS84 longitude/latitude" if building.georef
                        else "plan metres (the plan has no georef: not WGS84; see "
                             "'firenav map georef')"))
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
