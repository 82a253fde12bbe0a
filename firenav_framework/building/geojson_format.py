"""The native plan format: one GeoJSON FeatureCollection (see docs/building-format.md).

Every feature has ``properties.kind`` (floor, wall, door, opening, room, stair, obstacle,
anchor, entrance, georef) and, except the georef, ``properties.floor`` (the floor
index). Coordinates are plan metres (not WGS84), so plans can be drawn in QGIS or any
GeoJSON editor with a local metric CRS. Only the x and y of each coordinate are read.
"""
from __future__ import annotations

import json
import math
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np
import shapely
from shapely.geometry import Polygon, shape
from shapely.geometry.base import BaseGeometry

from .check import JOIN_TOL
from .crs_input import to_plan_metres
from .georef import GeoRef
from .limits import (MAX_FEATURES, MAX_ITEMS_PER_FLOOR, MAX_WALL_CONTACTS_PER_FLOOR,
                     MAX_WALL_SEGMENTS, MAX_WALL_SEGMENTS_PER_FLOOR, check_coordinates,
                     check_count, check_floor_count, check_level)
from .model import (Anchor, Building, BuildingError, Door, Entrance, Floor, Obstacle, Room,
                    Stair)
from .wall_merge import merge_overlapping

__all__ = ["read_geojson", "parse_geojson", "write_geojson", "dump_plan", "KINDS",
           "DEFAULT_FLOOR_HEIGHT"]

KINDS = ("floor", "wall", "door", "opening", "room", "stair", "obstacle", "anchor",
         "entrance", "georef", "stair_footprint")

#: Floor-to-floor height [m] assumed by importers that do not know it.
DEFAULT_FLOOR_HEIGHT = 3.0


class _Feature:
    """One parsed feature with the context needed for error messages."""

    def __init__(self, where: str, kind: str, props: dict[str, Any], geom: BaseGeometry | None):
        self.where, self.kind, self.props, self.geom = where, kind, props, geom

    def fail(self, what: str) -> BuildingError:
        return BuildingError(f"{self.where}: {what}")

    def number(self, key: str, default: float | None = None, *, positive: bool = False,
               nonneg: bool = False) -> float:
        value = self.props.get(key, default)
        if value is None:
            raise self.fail(f"missing property {key!r}")
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise self.fail(f"property {key!r} must be a finite number, got {value!r}")
        if positive and value <= 0:
            raise self.fail(f"property {key!r} must be > 0, got {value!r}")
        if nonneg and value < 0:
            raise self.fail(f"property {key!r} must be >= 0, got {value!r}")
        return float(value)

    def integer(self, key: str, default: int | None = None) -> int:
        value = self.props.get(key, default)
        if value is None:
            raise self.fail(f"missing property {key!r}")
        if isinstance(value, bool) or not isinstance(value, (int, float)) or value != int(value):
            raise self.fail(f"property {key!r} must be an integer, got {value!r}")
        return int(value)

    def text(self, key: str, default: str = "") -> str:
        value = self.props.get(key, default)
        if value is None:
            return default
        if not isinstance(value, (str, int)) or isinstance(value, bool):
            raise self.fail(f"property {key!r} must be a string, got {value!r}")
        return str(value)

    def geometry(self, *types: str) -> BaseGeometry:
        # GIS tools save single shapes as one-part Multi* geometries: take the part.
        g = self.geom
        if (g is not None and g.geom_type not in types and g.geom_type.startswith("Multi")
                and g.geom_type[5:] in types and len(g.geoms) == 1):
            self.geom = g.geoms[0]
        if self.geom is None or self.geom.geom_type not in types:
            got = "no geometry" if self.geom is None else self.geom.geom_type
            raise self.fail(f"a {self.kind} needs a {' or '.join(types)} geometry, got {got}")
        return self.geom


def _parse_geometry(where: str, geom: Any) -> BaseGeometry | None:
    if geom is None:
        return None
    if not isinstance(geom, dict) or "type" not in geom:
        raise BuildingError(f"{where}: geometry must be a GeoJSON geometry object")
    try:
        g = shape(_xy_only(geom))
    except RecursionError:
        raise BuildingError(f"{where}: {geom.get('type')} coordinates nested too deeply") from None
    except Exception as exc:  # shapely raises assorted types for malformed input
        raise BuildingError(f"{where}: malformed {geom.get('type')} geometry ({exc})") from None
    if g.is_empty:
        raise BuildingError(f"{where}: empty {geom.get('type')} geometry")
    check_coordinates(where, np.concatenate([c[:, :2] for c in _coords(g)]))
    return g


def _xy_only(geom: dict) -> dict:
    """Drop any z (or m) ordinate so 3-D editors' output reads as plan geometry."""
    def strip(c):
        if isinstance(c, list) and c and isinstance(c[0], (int, float)):
            return c[:2]
        if isinstance(c, list):
            return [strip(x) for x in c]
        return c
    out = dict(geom)
    if "coordinates" in out:
        out["coordinates"] = strip(out["coordinates"])
    return out


def _coords(g: BaseGeometry) -> list[np.ndarray]:
    if hasattr(g, "geoms"):
        return [c for part in g.geoms for c in _coords(part)]
    if isinstance(g, Polygon):
        return [np.asarray(g.exterior.coords)] + [np.asarray(r.coords) for r in g.interiors]
    return [np.asarray(g.coords)]


def read_geojson(path: str | Path) -> Building:
    """Load a native plan. Raises :class:`BuildingError` naming the file and feature."""
    from .loader import read_plan_json
    path = Path(path)
    return parse_geojson(read_plan_json(path), where=str(path), source=path,
                         default_name=path.stem)


def parse_geojson(data: Any, *, where: str = "<plan>", source: Path | None = None,
                  default_name: str = "building", merge_walls: bool = False) -> Building:
    """Build the model from an already-decoded native plan (a FeatureCollection dict).

    ``merge_walls`` (importers): collinear wall segments drawn twice are merged into one
    and listed in ``Building.notes``; in a native plan ``map check`` reports them instead.
    A collection in WGS84 or a projected CRS (see :mod:`.crs_input`) is converted to
    plan metres first, and the plan keeps the georef used.
    """
    if not isinstance(data, dict) or data.get("type") != "FeatureCollection":
        raise BuildingError(f"{where}: a plan must be a GeoJSON FeatureCollection")
    data, crs_georef, crs_notes = to_plan_metres(data, where)
    raw = data.get("features")
    if not isinstance(raw, list):
        raise BuildingError(f"{where}: 'features' must be a list")
    check_count(where, "features", len(raw), MAX_FEATURES)
    features = []
    for i, f in enumerate(raw):
        props = f.get("properties") if isinstance(f, dict) else None
        if isinstance(props, dict) and props.get("id") is None and isinstance(f.get("id"), (str, int)):
            props = {**props, "id": f["id"]}          # the Feature's own id (RFC 7946 3.2)
        fid = props.get("id") if isinstance(props, dict) else None
        at = f"{where}: feature {i}" + (f" (id {fid!r})" if fid is not None else "")
        if not isinstance(f, dict) or f.get("type") != "Feature":
            raise BuildingError(f"{at}: not a GeoJSON Feature")
        if not isinstance(props, dict):
            raise BuildingError(f"{at}: missing 'properties'")
        kind = props.get("kind")
        if kind not in KINDS:
            raise BuildingError(f"{at}: property 'kind' must be one of {', '.join(KINDS)}, "
                                f"got {kind!r}")
        features.append(_Feature(at, kind, props, _parse_geometry(at, f.get("geometry"))))
    name = data.get("name") if isinstance(data.get("name"), str) else default_name
    building = _assemble(features, name=name, source=source, where=where, merge_walls=merge_walls)
    if crs_georef is not None:
        building.georef = crs_georef
        building.notes[:0] = crs_notes
    return building


def _assemble(features: list[_Feature], *, name: str, source: Path | None, where: str,
              merge_walls: bool) -> Building:
    """The model from parsed features: floors first, then everything placed on them."""
    floors_meta: dict[int, tuple[float, float, str, BaseGeometry | None]] = {}
    for f in features:
        if f.kind == "floor":
            i = f.integer("floor")
            if i in floors_meta:
                raise f.fail(f"floor {i} is declared twice")
            outline = None
            if f.geom is not None:
                outline = f.geometry("Polygon", "MultiPolygon")
                if not outline.is_valid:
                    raise f.fail("floor outline polygon is not valid (self-intersecting?)")
            z, height = f.number("z"), f.number("height", positive=True)
            check_level(f.where, "z", z)
            check_level(f.where, "height", height)
            floors_meta[i] = (z, height, f.text("name", str(i)), outline)
    if not floors_meta:
        raise BuildingError(f"{where}: no 'floor' features: declare each floor with "
                            "kind=floor, floor=<index>, z=<level m>, height=<m>")
    n = len(floors_meta)
    check_floor_count(where, n)
    if sorted(floors_meta) != list(range(n)):
        raise BuildingError(f"{where}: floors must be numbered 0..{n - 1} without gaps, "
                            f"got {sorted(floors_meta)}")
    per_floor: dict[int, dict[str, list]] = defaultdict(lambda: defaultdict(list))
    anchors, entrances, georefs = [], [], []
    counters: dict[str, int] = defaultdict(int)

    def fid(f: _Feature, floor: int) -> str:
        counters[f.kind] += 1
        return f.text("id") or f"{f.kind}{floor}_{counters[f.kind]}"

    def floor_of(f: _Feature) -> int:
        i = f.integer("floor")
        if i not in floors_meta:
            raise f.fail(f"floor {i} is not a declared floor (floors 0..{n - 1})")
        return i

    footprints = {f.text("id"): f.geometry("Polygon") for f in features
                  if f.kind == "stair_footprint"}
    for f in features:
        if f.kind in ("floor", "georef", "stair_footprint"):
            continue
        fl = floor_of(f)
        ident = fid(f, fl)
        bucket = per_floor[fl]
        if f.kind == "wall":
            g = f.geometry("LineString", "MultiLineString")
            segs = _segments(f, g)
            bucket["walls"].extend(segs)
            bucket["wall_ids"].extend([ident] * len(segs))
        elif f.kind in ("door", "opening"):
            g = f.geometry("LineString")
            pts = _distinct(np.asarray(g.coords))
            if len(pts) != 2:
                raise f.fail(f"a {f.kind} is a LineString of its two jamb points, "
                             f"got {len(pts)} distinct points")
            bucket[f.kind + "s"].append(Door.from_jambs(ident, fl, pts[0], pts[1], kind=f.kind))
        elif f.kind == "room":
            bucket["rooms"].append(Room(ident, fl, f.geometry("Polygon"), f.text("name"),
                                        f.text("use", "room")))
        elif f.kind == "obstacle":
            g = f.geometry("Polygon")
            bucket["obstacles"].append(Obstacle(ident, fl, g))
        elif f.kind == "stair":
            g = f.geometry("LineString")
            path = _distinct(np.asarray(g.coords))
            if len(path) < 2:
                raise f.fail("a stair is its walking line from bottom to top: a LineString "
                             "of at least two distinct points")
            to = f.integer("floor_to")  # may name a missing floor: `map check` reports it
            z_from = floors_meta[fl][0]
            z_to = floors_meta[to][0] if to in floors_meta else z_from + floors_meta[fl][1]
            n_steps = f.integer("n_steps", 0)
            if n_steps < 0 or ("n_steps" in f.props and n_steps == 0):
                raise f.fail(f"property 'n_steps' must be a positive count, got {n_steps}")
            bucket["stairs"].append(Stair(ident, fl, to, path, f.number("width", 1.0, positive=True),
                                          z_from, z_to, n_steps,
                                          _footprint(f) or footprints.get(ident)))
        elif f.kind == "anchor":
            p = np.asarray(f.geometry("Point").coords[0])
            z = floors_meta[fl][0] + f.number("height", 0.0)
            anchors.append(Anchor(ident, f.text("anchor_kind", "uwb"), np.array([p[0], p[1], z]), fl))
        elif f.kind == "entrance":
            p = np.asarray(f.geometry("Point").coords[0])
            heading = f.props.get("heading_deg")
            entrances.append((f, ident, fl, p, None if heading is None else
                              math.radians(f.number("heading_deg")), f.text("door") or None))
    for f in features:
        if f.kind == "georef":
            p = np.asarray(f.geometry("Point").coords[0])
            try:
                georefs.append(GeoRef.at_point(p, f.number("lat"), f.number("lon"),
                                               f.number("bearing_deg", 0.0),
                                               f.number("alt", 0.0)))
            except ValueError as exc:
                raise f.fail(str(exc)) from None
    if len(georefs) > 1:
        raise BuildingError(f"{where}: more than one georef feature")

    floors = []
    notes: list[str] = []
    total_segments = 0
    for i in range(n):
        z, height, fname, outline = floors_meta[i]
        b = per_floor[i]
        at = f"{where}: floor {i}"
        check_count(at, "rooms, doors, openings, obstacles and stairs",
                    sum(len(b[k]) for k in ("doors", "openings", "rooms", "stairs", "obstacles")),
                    MAX_ITEMS_PER_FLOOR)
        if merge_walls and b["walls"]:
            segs, ids, merges = merge_overlapping(np.array(b["walls"]), b["wall_ids"], JOIN_TOL)
            b["walls"], b["wall_ids"] = list(segs), ids
            if merges:
                notes.append(f"floor {i}: {len(merges)} wall(s) drawn twice merged: " + "; ".join(
                    f"{', '.join(others) or 'a repeated segment'} into {kept} at "
                    f"({p[0]:.2f}, {p[1]:.2f})" for kept, others, p in merges))
        floor = make_floor(i, z, height, fname, b["walls"], b["wall_ids"], doors=b["doors"],
                           openings=b["openings"], rooms=b["rooms"], stairs=b["stairs"],
                           obstacles=b["obstacles"], drawn_outline=outline, where=at)
        total_segments += len(floor.walls)
        check_count(where, "wall segments in the building", total_segments, MAX_WALL_SEGMENTS)
        floors.append(floor)
    ents = [_entrance(f, floors, ident, fl, p, heading, door)
            for f, ident, fl, p, heading, door in entrances]
    return _with_context(where, lambda: Building(name=name, floors=floors, anchors=anchors,
                                                 entrances=ents,
                                                 georef=georefs[0] if georefs else None,
                                                 source=source, notes=notes))


def _footprint(f: _Feature) -> Polygon | None:
    """A stair's optional ``footprint`` property: its outline ring [[x, y], ...] [m]."""
    ring = f.props.get("footprint")
    if ring is None:
        return None
    try:
        pts = np.asarray(ring, dtype=float)
    except (TypeError, ValueError):
        raise f.fail("property 'footprint' must be a ring of [x, y] points") from None
    if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) < 3:
        raise f.fail("property 'footprint' must be a ring of at least three [x, y] points")
    check_coordinates(f.where, pts)
    poly = Polygon(pts)
    if not poly.is_valid or poly.area <= 0:
        raise f.fail("property 'footprint' is not a valid polygon (self-intersecting or flat)")
    return poly


def _with_context(where: str, make):
    try:
        return make()
    except BuildingError as exc:
        raise BuildingError(f"{where}: {exc}") from None


def _distinct(pts: np.ndarray) -> np.ndarray:
    """Drop consecutive repeated vertices (editors leave them on a double click)."""
    keep = np.ones(len(pts), dtype=bool)
    keep[1:] = np.any(np.abs(np.diff(pts, axis=0)) > 1e-9, axis=1)
    return pts[keep]


def _segments(f: _Feature, g: BaseGeometry) -> list[np.ndarray]:
    segs = []
    for line in getattr(g, "geoms", [g]):
        pts = _distinct(np.asarray(line.coords))
        if len(pts) < 2:
            raise f.fail("wall has no length (all its points coincide)")
        segs.extend(np.stack([pts[:-1], pts[1:]], axis=1))
    return segs


def make_floor(index: int, z: float, height: float, name: str, walls: list[np.ndarray],
               wall_ids: list[str], *, doors: list[Door], openings: list[Door],
               rooms: list[Room], stairs: list[Stair], obstacles: list[Obstacle],
               drawn_outline: BaseGeometry | None = None, where: str = "") -> Floor:
    """A Floor with obstacle edges appended to the walls and each door tied to its wall.

    Raises :class:`BuildingError` (prefixed with ``where``) when the floor exceeds the
    segment or wall-contact limits of :mod:`.limits`.
    """
    check_count(where or f"floor {index}", "wall segments (obstacle edges included)",
                len(walls) + sum(len(o.polygon.exterior.coords) - 1 for o in obstacles),
                MAX_WALL_SEGMENTS_PER_FLOOR)
    all_walls = list(walls)
    ids = list(wall_ids)
    n_drawn = len(all_walls)
    for o in obstacles:
        ring = np.asarray(o.polygon.exterior.coords)
        edges = np.stack([ring[:-1], ring[1:]], axis=1)
        all_walls.extend(edges)
        ids.extend([o.id] * len(edges))
    is_obst = np.zeros(len(all_walls), dtype=bool)
    is_obst[n_drawn:] = True
    floor = Floor(index=index, z=z, height=height, name=name,
                  walls=np.array(all_walls).reshape(-1, 2, 2), wall_ids=ids,
                  wall_is_obstacle=is_obst, doors=doors, openings=openings, rooms=rooms,
                  stairs=stairs, obstacles=obstacles, drawn_outline=drawn_outline)
    _check_wall_contacts(floor, where or f"floor {index}")
    _attach_doors_to_walls(floor)
    return floor


def _check_wall_contacts(floor: Floor, where: str) -> None:
    """Refuse a floor whose walls touch or cross each other more than
    :data:`~.limits.MAX_WALL_CONTACTS_PER_FLOOR` times (counted up to the limit only)."""
    w = floor.walls
    if len(w) < 2:
        return
    cap = len(w) + 2 * MAX_WALL_CONTACTS_PER_FLOOR  # each segment touches itself once
    if floor.wall_index.count_hits(w[:, 0], w[:, 1], cap + 1) > cap:
        raise BuildingError(f"{where}: its {len(w)} wall segments touch or cross each other "
                            f"more than {MAX_WALL_CONTACTS_PER_FLOOR} times (real walls meet "
                            "at their ends; is the drawing damaged or on the wrong layer?)")


def _attach_doors_to_walls(floor: Floor, tol: float = 0.15) -> None:
    """Set ``Door.wall`` to a drawn wall in line with the door that ends at one of its jambs."""
    gaps = floor.doors + floor.openings
    if not gaps or not len(floor.walls):
        return
    jambs = np.array([d.jambs for d in gaps]).reshape(-1, 2)
    dist, _, which = floor.nearest_wall(jambs)
    for k, d in enumerate(gaps):
        for j in (2 * k, 2 * k + 1):
            w = which[j]
            if dist[j] > tol or w < 0 or floor.wall_is_obstacle[w]:
                continue
            seg = floor.walls[w]
            e = seg[1] - seg[0]
            # In line: the wall runs across the door axis (|cos| small).
            if abs(np.dot(e, d.axis)) <= 0.2 * np.linalg.norm(e):
                d.wall = int(w)
                break


def _entrance(f: _Feature, floors: list[Floor], ident: str, fl: int, p: np.ndarray,
              heading: float | None, door_id: str | None) -> Entrance:
    """An entrance; without ``heading_deg`` it takes the axis of its door pointed inwards."""
    floor = floors[fl]
    gaps = floor.doors + floor.openings
    door = None
    if door_id is not None:
        door = next((g for g in gaps if g.id == door_id), None)
        if door is None:
            raise f.fail(f"entrance names door {door_id!r}, which floor {fl} does not have")
    elif gaps:
        d = np.array([np.linalg.norm(g.center - p) for g in gaps])
        if d.min() <= 2.0:
            door = gaps[int(d.argmin())]
    if heading is None:
        if door is None:
            raise f.fail("entrance has no 'heading_deg' and no door within 2 m to take it from")
        axis = door.axis
        if not floor.inside(door.center + 0.5 * axis)[0]:
            axis = -axis
        heading = math.atan2(axis[1], axis[0])
    return Entrance(ident, fl, p, heading, door.id if door is not None else None)


# ---------------------------------------------------------------------- writing

def _r(a: np.ndarray) -> list:
    return np.round(np.asarray(a, dtype=float), 4).tolist()


def _feature(kind: str, geometry: dict | None, **props) -> dict:
    return {"type": "Feature", "properties": {"kind": kind, **props}, "geometry": geometry}


def _line(points: np.ndarray) -> dict:
    return {"type": "LineString", "coordinates": _r(points)}


def _polygon(poly: BaseGeometry) -> dict:
    def rnd(c):
        return round(c, 4) if isinstance(c, float) else [rnd(x) for x in c]
    g = json.loads(shapely.to_geojson(poly))
    g["coordinates"] = rnd(g["coordinates"])
    return g


def write_geojson(building: Building, path: str | Path) -> None:
    """Write ``building`` in the native format (coordinates rounded to 0.1 mm)."""
    feats: list[dict] = []
    for fl in building.floors:
        feats.append(_feature("floor", None if fl.drawn_outline is None else _polygon(fl.drawn_outline),
                              floor=fl.index, z=fl.z, height=fl.height, name=fl.name))
        groups: dict[str, list[np.ndarray]] = defaultdict(list)
        for seg, wid, obst in zip(fl.walls, fl.wall_ids, fl.wall_is_obstacle):
            if not obst:
                groups[wid].append(seg)
        for wid, segs in groups.items():
            chain = all(np.array_equal(a[1], b[0]) for a, b in zip(segs, segs[1:]))
            geom = (_line(np.vstack([segs[0][:1]] + [s[1:] for s in segs])) if chain else
                    {"type": "MultiLineString", "coordinates": [_r(s) for s in segs]})
            feats.append(_feature("wall", geom, floor=fl.index, id=wid))
        for d in fl.doors + fl.openings:
            feats.append(_feature(d.kind, _line(d.jambs), floor=fl.index, id=d.id))
        for r in fl.rooms:
            feats.append(_feature("room", _polygon(r.polygon), floor=fl.index, id=r.id,
                                  name=r.name, use=r.use))
        for s in fl.stairs:
            props = dict(floor_to=s.floor_to, width=s.width, n_steps=s.n_steps)
            if s.polygon.symmetric_difference(s.default_polygon()).area > 1e-6:
                props["footprint"] = _r(shapely.get_exterior_ring(s.polygon).coords)
            feats.append(_feature("stair", _line(s.path), floor=fl.index, id=s.id, **props))
        for o in fl.obstacles:
            feats.append(_feature("obstacle", _polygon(o.polygon), floor=fl.index, id=o.id))
    for a in building.anchors:
        feats.append(_feature("anchor", {"type": "Point", "coordinates": _r(a.position[:2])},
                              floor=a.floor, id=a.id, anchor_kind=a.kind,
                              height=round(float(a.position[2] - building.floor(a.floor).z), 4)))
    for e in building.entrances:
        props = {"floor": e.floor, "id": e.id,
                 "heading_deg": round(math.degrees(e.heading), 3)}
        if e.door is not None:
            props["door"] = e.door
        feats.append(_feature("entrance", {"type": "Point", "coordinates": _r(e.position)}, **props))
    if building.georef is not None:
        g = building.georef
        feats.append(_feature("georef", {"type": "Point", "coordinates": list(map(float, g.anchor))},
                              lat=g.lat, lon=g.lon, alt=g.alt, bearing_deg=g.bearing))
    doc = {"type": "FeatureCollection", "name": building.name, "features": feats}
    Path(path).write_text(dump_plan(doc), encoding="utf-8")


def dump_plan(doc: dict) -> str:
    """A plan FeatureCollection as JSON text with one feature per line (readable diffs)."""
    head = {k: v for k, v in doc.items() if k != "features"}
    lines = ",\n".join(json.dumps(f) for f in doc["features"])
    return json.dumps(head)[:-1] + ', "features": [\n' + lines + "\n]}\n"
