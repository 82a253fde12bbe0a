"""Import of Aamks building exports (the obstacle JSON of the ORCA paper, Sec. 2.2).

Aamks (github.com/aamks) draws buildings in its editor and exports JSON in
**centimetres** (every coordinate and z value here is divided by 100). Three shapes
are read, as Aamks writes them:

* ``*.cad.json`` (what the user drew): ``{"0": {"ROOM": [...], "COR": [...], ...}}``,
  each record with ``points`` and a ``z`` range ``[z0, z1]``. ROOM, COR, HALL and STAI
  are compartments (rooms); DOOR, DCLOSER, DELECTR are doors and HOLE an opening
  (rectangles across a wall); OBST polygons are obstacles. WIN, VVENT, MVENT, FIRE,
  EVACUEE, FLOOR_TELEPORT_*, VSTAI and UNDERLAY_* are not plan geometry (counted in the
  notes). Walls are the room outlines minus the door and hole rectangles. A STAI or
  HALL whose z range rises 2 m or more above everything else on its floor is a
  *tower*: as Aamks does, a slice of it named ``<name>.<floor>`` is put on every other
  floor whose level lies in its z range.
* ``*.static.json`` (what Aamks derives for its evacuation model):
  ``{"floors": {"0": {"floor_meta", "rooms", "doors", "obstacles"}}}`` with the tower
  slices already among the rooms. Walls are 4 cm rectangles along every compartment
  edge in ``obstacles``: each becomes its centre line, lengthened by half its thickness
  at both ends so that walls meeting at a corner touch. A wall shared by two rooms is
  written once per room, and butt-joined walls overlap by their thickness: those are
  merged (listed in ``Building.notes``). HOLEs are cut from the walls but not listed:
  a gap in the wall two rooms share becomes an opening (noted). Polygons that are not
  thin (short side > 0.5 m, or less than twice as long as wide) are obstacles;
  obstacles without area (placeholders Aamks writes when obstacles are skipped) are
  skipped and counted.
* ``{"obstacles": {"1": [[[x, y], ...], ...]}}``: only the per-floor obstacle rectangles,
  as printed in the ORCA paper (floors 3 m apart, z from 0).

Floor levels are the lowest z of each floor's rooms (``floor_meta.minz_abs`` in
static exports) and storey heights the gaps between levels; the top storey takes the
height of its rooms (static: ``maxz_abs - minz_abs``) when that is plausible, else
the storey below. Aamks's own ``zdim`` (the top of anything on the floor, vents and
tall obstacles included, minus the floor below's top) is compared and a disagreement
noted. Stairwells (STAI towers) become stairs between each pair of floors they serve,
laid out from their footprint and doors (:mod:`.stairwells`). Doors on the building
outline become entrances. Ids are Aamks's names (``r2``, ``c3``, ``s5.1``, ``d7``,
letter and idx as in its geometry map) with ``@<floor>``, the same from both exports.
"""
from __future__ import annotations

import json
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import shapely
from shapely.geometry import Polygon, shape

from .check import JOIN_TOL, MAX_STOREY, MIN_STOREY, open_stretches, wall_cover
from .geojson_format import DEFAULT_FLOOR_HEIGHT, parse_geojson
from .limits import check_coordinates, check_floor_count, check_level
from .model import Building, BuildingError
from .sketch import FloorSketch
from .stairwells import DOOR_TOL, StairwellSlice, stairwell_stairs

__all__ = ["is_aamks", "parse_aamks", "door_feature_from_rectangle", "CM"]

#: Aamks length unit in metres (centimetres).
CM = 0.01
#: Thickest polygon [m] still read as a wall (thicker ones are obstacles).
MAX_WALL_THICKNESS = 0.5
#: How far [m] a STAI or HALL must rise above the rest of its floor to be a tower
#: (Aamks's own rule, 200 cm).
TOWER_MARGIN = 2.0

_ROOM_USE = {"ROOM": "room", "COR": "corridor", "HALL": "hall", "STAI": "stairwell"}
_TOWERS = ("STAI", "HALL")
_DOOR_TYPES = {"DOOR": "door", "DCLOSER": "door", "DELECTR": "door", "HOLE": "opening"}
#: Aamks's name letters (its geometry map): a record's name is the letter and its idx.
_LETTER = {"ROOM": "r", "COR": "c", "HALL": "a", "STAI": "s", "DOOR": "d", "DCLOSER": "q",
           "DELECTR": "e", "HOLE": "z", "OBST": "t"}
_NOT_GEOMETRY = ("WIN", "VVENT", "MVENT", "FIRE", "EVACUEE", "FLOOR_TELEPORT_UP",
                 "FLOOR_TELEPORT_DOWN", "VSTAI", "UNDERLAY_IMG", "UNDERLAY_FLOOR",
                 "UNDERLAY_SCALER")


def is_aamks(data: Any) -> bool:
    """Does decoded JSON look like one of the Aamks export shapes?"""
    if not isinstance(data, dict) or not data:
        return False
    if isinstance(data.get("floors"), dict) or isinstance(data.get("obstacles"), (dict, list)):
        return True
    return all(isinstance(v, dict) and any(k in v for k in _ROOM_USE) for v in data.values())


# ---------------------------------------------------------------------- values

def _json_value(where: str, raw: Any, what: str) -> Any:
    if isinstance(raw, str):
        try:
            return json.loads(raw)
        except RecursionError:
            raise BuildingError(f"{where}: {what} string nested too deeply") from None
        except ValueError:
            raise BuildingError(f"{where}: {what} string is not a JSON array: {raw[:60]!r}") from None
    return raw


def _points(where: str, raw: Any) -> np.ndarray:
    """(K, 2) metres from an Aamks point list (a JSON array or a string holding one)."""
    raw = _json_value(where, raw, "points")
    try:
        pts = np.asarray(raw, dtype=float)
    except (TypeError, ValueError, OverflowError):
        raise BuildingError(f"{where}: points must be a list of [x, y] pairs") from None
    if pts.ndim != 2 or pts.shape[1] < 2 or len(pts) < 3:
        raise BuildingError(f"{where}: points must be at least three [x, y] pairs, got "
                            f"shape {pts.shape}")
    pts = pts[:, :2] * CM
    check_coordinates(where, pts)
    if np.allclose(pts[0], pts[-1]):
        pts = pts[:-1]
    return pts


def _polygon(where: str, raw: Any) -> Polygon:
    poly = Polygon(_points(where, raw))
    if poly.area <= 0:
        raise BuildingError(f"{where}: polygon has no area")
    return poly


def _z_range(where: str, raw: Any) -> tuple[float, float]:
    raw = _json_value(where, raw, "z")
    try:
        z0, z1 = (float(v) * CM for v in raw)
    except (TypeError, ValueError, OverflowError):
        raise BuildingError(f"{where}: z must be [z0, z1] in cm, got {raw!r}") from None
    for v in (z0, z1):
        if not np.isfinite(v):
            raise BuildingError(f"{where}: z must be finite, got {raw!r}")
        check_level(where, "z", v)
    return z0, z1


def _mapping(at: str, value: Any, what: str) -> dict:
    if value is None:
        return {}
    if not isinstance(value, dict) or not all(isinstance(v, dict) for v in value.values()):
        raise BuildingError(f"{at}: {what} must be an object of named objects")
    return value


def _list(at: str, value: Any, what: str, of_dicts: bool = True) -> list:
    if value is None:
        return []
    if not isinstance(value, list) or (of_dicts and not all(isinstance(v, dict) for v in value)):
        raise BuildingError(f"{at}: {what} must be a list{' of objects' if of_dicts else ''}")
    return value


def _cm(at: str, meta: dict, key: str, default: float | None) -> float | None:
    """A length in metres from an Aamks value in centimetres (``default`` if absent)."""
    value = meta.get(key)
    if value is None:
        return default
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value):
        raise BuildingError(f"{at}: {key} must be a number of centimetres, got {value!r}")
    check_level(at, key, float(value) * CM)
    return float(value) * CM


def _floor_keys(where: str, floors: dict) -> list[str]:
    def key(k: str) -> float:
        try:
            return float(k)
        except ValueError:
            raise BuildingError(f"{where}: floor name {k!r} is not a number") from None
    check_floor_count(where, len(floors))
    return sorted(floors, key=key)


# ---------------------------------------------------------------------- geometry

def _rectangle(poly: Polygon) -> tuple[np.ndarray, np.ndarray, float, float]:
    """Centre, unit long axis, long side and short side [m] of a polygon's minimum rectangle."""
    rect = np.asarray(shapely.minimum_rotated_rectangle(poly).exterior.coords)[:4]
    e1, e2 = rect[1] - rect[0], rect[2] - rect[1]
    l1, l2 = float(np.hypot(*e1)), float(np.hypot(*e2))
    centre = rect.mean(axis=0)
    if l1 >= l2:
        return centre, e1 / l1, l1, l2
    return centre, e2 / l2, l2, l1


def _positive(v: np.ndarray) -> np.ndarray:
    """The sign of a direction that points towards +x (or +y when vertical)."""
    return -v if (v[0] < -1e-9 or (abs(v[0]) <= 1e-9 and v[1] < 0)) else v


def _is_wall(poly: Polygon) -> bool:
    _, _, long, short = _rectangle(poly)
    return short <= MAX_WALL_THICKNESS and long >= 2 * short and \
        poly.area >= 0.9 * long * short


def door_feature_from_rectangle(kind: str, ident: str, floor: int, poly: Polygon) -> dict:
    """Native door/opening feature from a door rectangle: width = long side, axis = short side
    (pointing to +x, or +y when the axis is vertical)."""
    centre, along, long, _ = _rectangle(poly)
    jambs = [centre - along * long / 2, centre + along * long / 2]
    # Keep the jamb order so the axis (left normal of jamb 1 -> 2) points to +x / +y.
    axis = np.array([-along[1], along[0]])
    if not np.allclose(_positive(axis), axis):
        jambs.reverse()
    return _feat(kind, {"type": "LineString", "coordinates": np.round(jambs, 4).tolist()},
                 floor=floor, id=ident)


def _feat(kind: str, geometry: dict | None, **props) -> dict:
    return {"type": "Feature", "properties": {"kind": kind, **props}, "geometry": geometry}


def _poly_geojson(poly: Polygon) -> dict:
    return {"type": "Polygon", "coordinates": [np.round(np.asarray(poly.exterior.coords), 4).tolist()]}


def _line_geojson(points: np.ndarray) -> dict:
    return {"type": "LineString", "coordinates": np.round(points, 4).tolist()}


def _wall_centre_line(poly: Polygon) -> np.ndarray:
    centre, along, long, short = _rectangle(poly)
    half = (long + short) / 2          # lengthened by half the thickness at each end
    return np.array([centre - along * half, centre + along * half])


# ---------------------------------------------------------------------- the common model

@dataclass
class _Floor:
    """One floor as read from either export, before it becomes native features."""

    key: str
    index: int
    z: float = 0.0
    height: float = DEFAULT_FLOOR_HEIGHT
    rooms: list[tuple[str, str, str, Polygon]] = field(default_factory=list)  # id, name, use, poly
    stairwells: dict[str, Polygon] = field(default_factory=dict)  # tower name -> slice
    doors: list[tuple[str, str, Polygon]] = field(default_factory=list)      # id, kind, rectangle
    walls: list[tuple[str, np.ndarray]] = field(default_factory=list)        # static centre lines
    obstacles: list[tuple[str, Polygon]] = field(default_factory=list)


def _storeys(where: str, floors: list[_Floor], top_hints: list[tuple[str, float | None]],
             notes: list[str]) -> None:
    """Storey heights from the levels; the top one from the first plausible hint
    (what, height [m] or None), else the storey below, else the default."""
    for lo, hi in zip(floors, floors[1:]):
        lo.height = hi.z - lo.z
        if not lo.height > 0:
            raise BuildingError(f"{where}: floor {hi.key!r} (level {hi.z:.2f} m) is not above floor "
                                f"{lo.key!r} (level {lo.z:.2f} m)")
    top = floors[-1]
    for what, h in top_hints:
        if h is not None and MIN_STOREY <= h <= MAX_STOREY:
            top.height = h
            notes.append(f"floor {top.key} (top): storey height {h:.2f} m from {what}")
            return
    if len(floors) > 1:
        top.height = floors[-2].height
        notes.append(f"floor {top.key} (top): storey height {top.height:.2f} m taken from "
                     "the storey below (the export gives no plausible one)")
    else:
        notes.append(f"floor {top.key}: storey height {top.height:.2f} m assumed (the "
                     "export gives no plausible one)")


def _stairs(floors: list[_Floor], door_feats: list[dict], notes: list[str]) -> list[dict]:
    """Stairs of every stairwell tower, from its slices and their doors."""
    by_name: dict[str, list[StairwellSlice]] = {}
    for fl in floors:
        jambs = [(f["properties"]["id"], np.asarray(f["geometry"]["coordinates"]))
                 for f in door_feats if f["properties"]["floor"] == fl.index]
        for name, poly in fl.stairwells.items():
            ring = poly.exterior
            doors = [(d, j) for d, j in jambs
                     if ring.distance(shapely.Point(j.mean(axis=0))) <= DOOR_TOL]
            by_name.setdefault(name, []).append(StairwellSlice(fl.index, fl.z, poly, doors))
    out = []
    for name, slices in by_name.items():
        feats, why = stairwell_stairs(name, slices)
        out += feats
        notes += why
    return out


def _entrances(feats: list[dict]) -> list[dict]:
    """Entrances at the doors that lie on the building outline of their floor."""
    out = []
    floors = sorted({f["properties"]["floor"] for f in feats if f["properties"]["kind"] == "floor"})
    for fl in floors:
        rooms = [shape(f["geometry"]) for f in feats
                 if f["properties"]["kind"] == "room" and f["properties"]["floor"] == fl]
        if not rooms:
            continue
        boundary = shapely.union_all(rooms).boundary
        for f in feats:
            p = f["properties"]
            if p["kind"] == "door" and p["floor"] == fl:
                a, b = np.asarray(f["geometry"]["coordinates"])
                mid = (a + b) / 2
                if boundary.distance(shapely.Point(mid)) < 0.2:
                    out.append(_feat("entrance", {"type": "Point", "coordinates": np.round(mid, 4).tolist()},
                                     floor=fl, id=f"entrance_{p['id']}", door=p["id"]))
    return out


def _door_features(fl: _Floor) -> list[dict]:
    return [door_feature_from_rectangle(kind, ident, fl.index, poly) for ident, kind, poly in fl.doors]


# ---------------------------------------------------------------------- static.json

def _read_static(data: dict, where: str, notes: list[str]) -> list[_Floor]:
    floors_in = data["floors"]
    floors: list[_Floor] = []
    hints: list[tuple[str, float | None]] = []
    zdims: list[float | None] = []
    for i, key in enumerate(_floor_keys(where, floors_in)):
        raw = floors_in[key]
        at = f"{where}: floors[{key!r}]"
        if not isinstance(raw, dict):
            raise BuildingError(f"{at}: must be an object with rooms/doors/obstacles")
        meta = raw.get("floor_meta") or {}
        if not isinstance(meta, dict):
            raise BuildingError(f"{at}.floor_meta: must be an object")
        mat = f"{at}.floor_meta"
        fl = _Floor(key, i, z=_cm(mat, meta, "minz_abs", 0.0))
        zdims.append(_cm(mat, meta, "zdim", None))
        top = _cm(mat, meta, "maxz_abs", None)
        hints = [("floor_meta maxz_abs - minz_abs", None if top is None else top - fl.z),
                 ("floor_meta zdim", zdims[-1])]
        for name, room in _mapping(at, raw.get("rooms"), "rooms").items():
            poly = _polygon(f"{at}.rooms[{name!r}]", room.get("points"))
            kind = room.get("type_sec", "ROOM")
            use = _ROOM_USE.get(kind, "room")
            fl.rooms.append((f"{name}@{key}", str(room.get("name", name)), use, poly))
            if kind == "STAI":
                fl.stairwells[str(name).split(".")[0]] = poly
        for name, door in _mapping(at, raw.get("doors"), "doors").items():
            kind = _DOOR_TYPES.get(door.get("type_sec", "DOOR"), "door")
            fl.doors.append((f"{name}@{key}", kind,
                             _polygon(f"{at}.doors[{name!r}]", door.get("points"))))
        flat = 0
        for k, raw_obst in enumerate(_list(at, raw.get("obstacles"), "obstacles", of_dicts=False)):
            poly = Polygon(_points(f"{at}.obstacles[{k}]", raw_obst))
            if poly.area <= 0:
                flat += 1
            elif _is_wall(poly):
                fl.walls.append((f"obstacle{k}@{key}", _wall_centre_line(poly)))
            else:
                fl.obstacles.append((f"obstacle{k}@{key}", poly))
        notes.append(f"floor {key}: {len(fl.walls)} thin obstacle rectangles read as wall "
                     f"centre lines, {len(fl.obstacles)} as obstacles"
                     + (f", {flat} without area skipped" if flat else ""))
        floors.append(fl)
    _storeys(where, floors, hints, notes)
    for fl, zdim in zip(floors, zdims):
        if zdim is not None and abs(zdim - fl.height) > 0.01:
            notes.append(f"floor {fl.key}: floor_meta zdim {zdim:.2f} m is not its storey "
                         f"height ({fl.height:.2f} m from the floor levels, used)")
    return floors


def _static_openings(fl: _Floor, door_feats: list[dict], notes: list[str]) -> list[dict]:
    """Openings where two rooms share an outline stretch that no wall or door closes
    (a HOLE: cut from the walls of a static export but not listed in it)."""
    segs = np.array([w for _, w in fl.walls]).reshape(-1, 2, 2)
    jambs = [np.asarray(f["geometry"]["coordinates"]) for f in door_feats]
    cover = wall_cover(segs, jambs)
    out: list[dict] = []
    done = []
    for k, (rid, rname, _, poly) in enumerate(fl.rooms):
        for piece in open_stretches(poly, cover):
            if any(d.buffer(JOIN_TOL).contains(piece) for d in done):
                continue
            other = next((o for o in fl.rooms[:k] + fl.rooms[k + 1:]
                          if o[3].boundary.buffer(JOIN_TOL).contains(piece)), None)
            if other is None:
                continue                      # on the outline: map check reports it
            ends = np.asarray(piece.coords)[[0, -1]]
            done.append(piece)
            ident = f"opening_{rname}_{other[1]}@{fl.key}"
            out.append(_feat("opening", _line_geojson(ends), floor=fl.index, id=ident))
            notes.append(f"floor {fl.key}: opening {ident} from ({ends[0][0]:.2f}, "
                         f"{ends[0][1]:.2f}) to ({ends[1][0]:.2f}, {ends[1][1]:.2f}), where "
                         f"rooms {rid} and {other[0]} share an outline without wall (a HOLE, "
                         "which static exports cut from the walls but do not list)")
    return out


def _static_features(floors: list[_Floor], notes: list[str]) -> list[dict]:
    feats: list[dict] = []
    doors: list[dict] = []
    for fl in floors:
        feats.append(_feat("floor", None, floor=fl.index, z=fl.z, height=fl.height, name=fl.key))
        for rid, name, use, poly in fl.rooms:
            feats.append(_feat("room", _poly_geojson(poly), floor=fl.index, id=rid, name=name,
                               use=use))
        fdoors = _door_features(fl)
        doors += fdoors
        feats += fdoors
        feats += [_feat("wall", _line_geojson(w), floor=fl.index, id=wid) for wid, w in fl.walls]
        feats += [_feat("obstacle", _poly_geojson(p), floor=fl.index, id=oid)
                  for oid, p in fl.obstacles]
        openings = _static_openings(fl, fdoors, notes)
        feats += openings
    feats += _stairs(floors, doors, notes)
    return feats


# ---------------------------------------------------------------------- cad.json

def _z_of(at: str, item: dict) -> tuple[float, float] | None:
    return _z_range(at, item["z"]) if "z" in item else None


def _z_extent(at: str, raw: dict) -> tuple[float, float]:
    """(lowest z0 of any record, highest z1 of any record but towers) [m] on a floor;
    an unreadable z on a record that is not plan geometry is passed over."""
    top, low = -np.inf, np.inf
    for t, items in raw.items():
        for k, item in enumerate(items if isinstance(items, list) else []):
            if not (isinstance(item, dict) and "z" in item):
                continue
            try:
                z0, z1 = _z_range(f"{at}.{t}[{k}]", item["z"])
            except BuildingError:
                if t not in _NOT_GEOMETRY:
                    raise
                continue
            low = min(low, z0)
            if t not in _TOWERS:
                top = max(top, z1)
    return low, top


def _cad_level(fl: _Floor, below: _Floor | None, room_z: list[tuple[float, float]],
               low: float, notes: list[str]) -> None:
    """A floor's level: the lowest z0 of its ROOM/COR records, else of any record."""
    if room_z:
        fl.z = min(z0 for z0, _ in room_z)
        if max(z0 for z0, _ in room_z) - fl.z > 0.01:
            notes.append(f"floor {fl.key}: its rooms start at levels from {fl.z:.2f} to "
                         f"{max(z0 for z0, _ in room_z):.2f} m; the lowest is the floor level")
    elif np.isfinite(low):
        fl.z = low
        notes.append(f"floor {fl.key}: no z on its rooms; level {fl.z:.2f} m from the lowest "
                     "of its other records")
    else:
        fl.z = below.z + DEFAULT_FLOOR_HEIGHT if below is not None else 0.0
        notes.append(f"floor {fl.key}: no z on its records; level {fl.z:.2f} m assumed")


def _cad_records(at: str, fl: _Floor, recs: dict[str, list], top: float) -> list[tuple]:
    """Rooms, doors and obstacles of one floor into ``fl``; the towers drawn on it
    (floor, type, name, footprint, z0, z1)."""
    towers = []
    for t, use in _ROOM_USE.items():
        for k, item in enumerate(recs[t]):
            poly = _polygon(f"{at}.{t}[{k}]", item.get("points"))
            name = f"{_LETTER[t]}{item.get('idx', k)}"
            fl.rooms.append((f"{name}@{fl.key}", name, use, poly))
            if t == "STAI":
                fl.stairwells[name] = poly
            z = _z_of(f"{at}.{t}[{k}]", item)
            if t in _TOWERS and z is not None and z[1] >= top + TOWER_MARGIN:
                towers.append((fl, t, name, poly, *z))
    for t, kind in _DOOR_TYPES.items():
        for k, item in enumerate(recs[t]):
            fl.doors.append((f"{_LETTER[t]}{item.get('idx', k)}@{fl.key}", kind,
                             _polygon(f"{at}.{t}[{k}]", item.get("points"))))
    for k, item in enumerate(recs["OBST"]):
        fl.obstacles.append((f"t{item.get('idx', k)}@{fl.key}",
                             _polygon(f"{at}.OBST[{k}]", item.get("points"))))
    return towers


def _slice_towers(floors: list[_Floor], towers: list[tuple], notes: list[str]) -> None:
    """Put a slice ``<name>.<floor>`` of each tower on every other floor whose level lies
    in its z range (as Aamks does)."""
    for home, t, name, poly, z0, z1 in towers:
        reached = [fl for fl in floors if fl is not home and z0 - 1e-6 <= fl.z < z1 - 1e-6]
        for fl in reached:
            sliced = f"{name}.{fl.key}"
            fl.rooms.append((f"{sliced}@{fl.key}", sliced, _ROOM_USE[t], poly))
            if t == "STAI":
                fl.stairwells[name] = poly
        if reached:
            notes.append(f"{t} {name}@{home.key} rises to {z1:.2f} m: also on floor(s) "
                         f"{', '.join(fl.key for fl in reached)} as {name}.<floor>")


def _read_cad(data: dict, where: str, notes: list[str]) -> list[_Floor]:
    floors = [_Floor(k, i) for i, k in enumerate(_floor_keys(where, data))]
    skipped: Counter[str] = Counter()
    scans = []
    for fl in floors:
        raw = data[fl.key]
        at = f"{where}: [{fl.key!r}]"
        if not isinstance(raw, dict):
            raise BuildingError(f"{at}: must be an object of ROOM, COR, DOOR, ... lists")
        recs = {t: _list(at, raw.get(t), t) for t in (*_ROOM_USE, *_DOOR_TYPES, "OBST")}
        for t in _NOT_GEOMETRY:
            if isinstance(raw.get(t), list) and raw[t]:
                skipped[t] += len(raw[t])
        room_z = [z for t in ("ROOM", "COR") for k, item in enumerate(recs[t])
                  if (z := _z_of(f"{at}.{t}[{k}]", item)) is not None]
        scans.append((at, recs, room_z, *_z_extent(at, raw)))
    for i, (fl, (_, _, room_z, low, _)) in enumerate(zip(floors, scans)):
        _cad_level(fl, floors[i - 1] if i else None, room_z, low, notes)
    top_rooms = scans[-1][2]
    _storeys(where, floors, [("the z range of its rooms", max(z1 for _, z1 in top_rooms)
                              - floors[-1].z if top_rooms else None)], notes)
    towers = [tw for fl, (at, recs, _, _, top) in zip(floors, scans)
              for tw in _cad_records(at, fl, recs, top)]
    _slice_towers(floors, towers, notes)
    if skipped:
        notes.append("not plan geometry, skipped: " + ", ".join(
            f"{n} {t}" for t, n in sorted(skipped.items())))
    return floors


def _cad_features(floors: list[_Floor], notes: list[str]) -> list[dict]:
    feats: list[dict] = []
    doors: list[dict] = []
    for fl in floors:
        sk = FloorSketch(fl.index, fl.z, fl.height, fl.key)
        for rid, name, use, poly in fl.rooms:
            sk.room(rid, list(poly.exterior.coords)[:-1], name=name, use=use)
        for f in _door_features(fl):
            a, b = np.asarray(f["geometry"]["coordinates"])
            d = b - a
            sk.door(f["properties"]["id"], tuple((a + b) / 2), float(np.hypot(*d)),
                    (-d[1], d[0]), kind=f["properties"]["kind"])
            doors.append(f)
        for oid, poly in fl.obstacles:
            sk.obstacle(oid, list(poly.exterior.coords)[:-1])
        feats += sk.features()
    notes.append("walls derived from the room outlines minus door and hole rectangles")
    feats += _stairs(floors, doors, notes)
    return feats


# ---------------------------------------------------------------------- entry

def _read_obstacles_only(data: dict, where: str, notes: list[str]) -> list[_Floor]:
    obstacles = data["obstacles"]
    if isinstance(obstacles, list):
        obstacles = {"0": obstacles}
    if not all(isinstance(v, list) for v in obstacles.values()):
        raise BuildingError(f"{where}: 'obstacles' must map floor names to lists of polygons")
    keys = _floor_keys(where, obstacles)
    static = {"floors": {k: {"floor_meta": {"name": k, "minz_abs": i * DEFAULT_FLOOR_HEIGHT / CM,
                                            "zdim": DEFAULT_FLOOR_HEIGHT / CM},
                             "obstacles": obstacles[k]}
                         for i, k in enumerate(keys)}}
    notes.append(f"obstacles-only file: floors assumed {DEFAULT_FLOOR_HEIGHT} m apart from z = 0")
    return _read_static(static, where, notes)


def parse_aamks(data: dict, *, where: str, source: Path | None = None,
                default_name: str = "aamks") -> Building:
    """Build the model from a decoded Aamks export (any of the three shapes)."""
    notes = ["Aamks units: centimetres (converted to metres)"]
    if isinstance(data.get("floors"), dict):
        feats = _static_features(_read_static(data, where, notes), notes)
    elif "obstacles" in data:
        feats = _static_features(_read_obstacles_only(data, where, notes), notes)
    else:
        feats = _cad_features(_read_cad(data, where, notes), notes)
    feats += _entrances(feats)
    building = parse_geojson({"type": "FeatureCollection", "name": default_name, "features": feats},
                             where=where, source=source, default_name=default_name,
                             merge_walls=True)
    building.notes[:0] = notes
    return building
