"""Import of Aamks building exports (the obstacle JSON of the ORCA paper, Sec. 2.2).

Aamks (github.com/aamks) draws buildings in CAD and exports JSON in **centimetres**
(every coordinate and z value here is divided by 100). Three shapes are read:

* ``*.static.json``: ``{"floors": {"0": {"floor_meta", "rooms", "doors", "obstacles"}}}``.
  Walls are thin rectangles in ``obstacles``; each becomes its centre line, lengthened
  by half the wall thickness at both ends so that walls meeting at a corner or a T touch
  (Aamks butts the rectangles against each other's faces). Polygons that are not thin
  (short side > 0.5 m or less than twice as long as wide) are obstacles (furniture).
* ``*.cad.json``: ``{"0": {"ROOM": [...], "COR": [...], "DOOR": [...], ...}}``, the drawn
  geometry: walls are the room outlines (ROOM, COR, HALL, STAI) minus the door (DOOR,
  DCLOSER, DELECTR) and hole (HOLE) rectangles; OBST polygons are obstacles.
* ``{"obstacles": {"1": [[[x, y], ...], ...]}}``: only the per-floor obstacle rectangles,
  as printed in the ORCA paper (floors 3 m apart, z from 0).

Points may be JSON arrays or, as Aamks writes them, strings holding a JSON array. A door
rectangle gives the door's centre, width (its long side) and axis (its short side).
Doors on the building outline become entrances. Aamks STAI polygons spanning two floor
levels become stairs along their long axis; Aamks does not say which end is the bottom,
so the end nearer the origin is taken (noted in ``Building.notes``).
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import shapely
from shapely.geometry import Polygon, shape

from .geojson_format import DEFAULT_FLOOR_HEIGHT, parse_geojson
from .model import Building, BuildingError
from .sketch import FloorSketch

__all__ = ["is_aamks", "parse_aamks", "door_feature_from_rectangle", "CM"]

#: Aamks length unit in metres (centimetres).
CM = 0.01
#: Thickest polygon [m] still read as a wall (thicker ones are obstacles).
MAX_WALL_THICKNESS = 0.5

_ROOM_USE = {"ROOM": "room", "COR": "corridor", "HALL": "hall", "STAI": "stairwell"}
_DOOR_TYPES = {"DOOR": "door", "DCLOSER": "door", "DELECTR": "door", "HOLE": "opening"}


def is_aamks(data: Any) -> bool:
    """Does decoded JSON look like one of the Aamks export shapes?"""
    if not isinstance(data, dict) or not data:
        return False
    if isinstance(data.get("floors"), dict) or isinstance(data.get("obstacles"), (dict, list)):
        return True
    return all(isinstance(v, dict) and any(k in v for k in _ROOM_USE) for v in data.values())


def _points(where: str, raw: Any) -> np.ndarray:
    """(K, 2) metres from an Aamks point list (a JSON array or a string holding one)."""
    if isinstance(raw, str):
        try:
            raw = json.loads(raw)
        except json.JSONDecodeError:
            raise BuildingError(f"{where}: points string is not a JSON array: {raw[:60]!r}") from None
    try:
        pts = np.asarray(raw, dtype=float)
    except (TypeError, ValueError):
        raise BuildingError(f"{where}: points must be a list of [x, y] pairs") from None
    if pts.ndim != 2 or pts.shape[1] < 2 or len(pts) < 3:
        raise BuildingError(f"{where}: points must be at least three [x, y] pairs, got "
                            f"shape {pts.shape}")
    if not np.all(np.isfinite(pts)):
        raise BuildingError(f"{where}: points contain NaN or infinite values")
    pts = pts[:, :2] * CM
    if np.allclose(pts[0], pts[-1]):
        pts = pts[:-1]
    return pts


def _polygon(where: str, raw: Any) -> Polygon:
    pts = _points(where, raw)
    poly = Polygon(pts)
    if poly.area <= 0:
        raise BuildingError(f"{where}: polygon has no area")
    return poly


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


def _z_range(where: str, raw: Any) -> tuple[float, float]:
    if isinstance(raw, str):
        try:
            raw = json.loads(raw)
        except json.JSONDecodeError:
            raise BuildingError(f"{where}: z must be [z0, z1], got {raw!r}") from None
    try:
        z0, z1 = (float(v) * CM for v in raw)
    except (TypeError, ValueError):
        raise BuildingError(f"{where}: z must be [z0, z1] in cm, got {raw!r}") from None
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


def _cm(at: str, meta: dict, key: str, default: float) -> float:
    """A length in metres from an Aamks value in centimetres."""
    value = meta.get(key, default)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value):
        raise BuildingError(f"{at}: {key} must be a number of centimetres, got {value!r}")
    return float(value) * CM


def _floor_keys(where: str, floors: dict) -> list[str]:
    def key(k: str) -> float:
        try:
            return float(k)
        except ValueError:
            raise BuildingError(f"{where}: floor name {k!r} is not a number") from None
    return sorted(floors, key=key)


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


def _wall_centre_line(poly: Polygon) -> np.ndarray:
    centre, along, long, short = _rectangle(poly)
    half = (long + short) / 2          # lengthened by half the thickness at each end
    return np.array([centre - along * half, centre + along * half])


def _read_static(data: dict, where: str, notes: list[str]) -> list[dict]:
    floors = data["floors"]
    feats: list[dict] = []
    for i, key in enumerate(_floor_keys(where, floors)):
        fl = floors[key]
        at = f"{where}: floors[{key!r}]"
        if not isinstance(fl, dict):
            raise BuildingError(f"{at}: must be an object with rooms/doors/obstacles")
        meta = fl.get("floor_meta") or {}
        if not isinstance(meta, dict):
            raise BuildingError(f"{at}.floor_meta: must be an object")
        z = _cm(f"{at}.floor_meta", meta, "minz_abs", 0.0)
        height = _cm(f"{at}.floor_meta", meta, "zdim", DEFAULT_FLOOR_HEIGHT / CM)
        feats.append(_feat("floor", None, floor=i, z=z, height=height, name=str(meta.get("name", key))))
        stairs: list[tuple[str, Polygon]] = []
        for name, room in _mapping(at, fl.get("rooms"), "rooms").items():
            poly = _polygon(f"{at}.rooms[{name!r}]", room.get("points"))
            use = _ROOM_USE.get(room.get("type_sec", "ROOM"), "room")
            feats.append(_feat("room", _poly_geojson(poly), floor=i, id=f"{name}@{key}",
                               name=str(room.get("name", name)), use=use))
            if use == "stairwell":
                stairs.append((name, poly))
        for name, door in _mapping(at, fl.get("doors"), "doors").items():
            kind = _DOOR_TYPES.get(door.get("type_sec", "DOOR"), "door")
            poly = _polygon(f"{at}.doors[{name!r}]", door.get("points"))
            feats.append(door_feature_from_rectangle(kind, f"{name}@{key}", i, poly))
        n_walls = n_obst = 0
        for k, raw in enumerate(_list(at, fl.get("obstacles"), "obstacles", of_dicts=False)):
            poly = _polygon(f"{at}.obstacles[{k}]", raw)
            if _is_wall(poly):
                n_walls += 1
                feats.append(_feat("wall", {"type": "LineString", "coordinates":
                                            np.round(_wall_centre_line(poly), 4).tolist()},
                                   floor=i, id=f"obstacle{k}@{key}"))
            else:
                n_obst += 1
                feats.append(_feat("obstacle", _poly_geojson(poly), floor=i, id=f"obstacle{k}@{key}"))
        notes.append(f"floor {key}: {n_walls} thin obstacle rectangles read as wall centre "
                     f"lines, {n_obst} as obstacles")
        feats += _stair_features(stairs, i, key, notes)
    return feats


def _read_cad(data: dict, where: str, notes: list[str]) -> list[dict]:
    feats: list[dict] = []
    keys = _floor_keys(where, data)
    levels = []
    for i, key in enumerate(keys):
        fl = data[key]
        at = f"{where}: [{key!r}]"
        zs = [_z_range(f"{at}.{t}[{k}]", item.get("z", "[0,0]"))
              for t in _ROOM_USE for k, item in enumerate(_list(at, fl.get(t), t))]
        z0 = min((z[0] for z in zs), default=i * DEFAULT_FLOOR_HEIGHT)
        z1 = max((z[1] for z in zs), default=z0 + DEFAULT_FLOOR_HEIGHT)
        levels.append((z0, z1 - z0 if z1 > z0 else DEFAULT_FLOOR_HEIGHT))
    for i, key in enumerate(keys):
        fl = data[key]
        at = f"{where}: [{key!r}]"
        sk = FloorSketch(i, levels[i][0], levels[i][1], key)
        stairs: list[tuple[str, Polygon]] = []
        for t, use in _ROOM_USE.items():
            for k, item in enumerate(_list(at, fl.get(t), t)):
                poly = _polygon(f"{at}.{t}[{k}]", item.get("points"))
                ident = f"{t.lower()}{item.get('idx', k)}@{key}"
                sk.room(ident, list(poly.exterior.coords)[:-1], use=use)
                if use == "stairwell":
                    stairs.append((ident, poly))
        for t, kind in _DOOR_TYPES.items():
            for k, item in enumerate(_list(at, fl.get(t), t)):
                poly = _polygon(f"{at}.{t}[{k}]", item.get("points"))
                door = door_feature_from_rectangle(kind, f"{t.lower()}{item.get('idx', k)}@{key}", i, poly)
                a, b = np.asarray(door["geometry"]["coordinates"])
                d = b - a
                sk.door(door["properties"]["id"], tuple((a + b) / 2), float(np.hypot(*d)),
                        (-d[1], d[0]), kind=kind)
        for k, item in enumerate(_list(at, fl.get("OBST"), "OBST")):
            poly = _polygon(f"{at}.OBST[{k}]", item.get("points"))
            sk.obstacle(f"obst{item.get('idx', k)}@{key}", list(poly.exterior.coords)[:-1])
        feats += sk.features()
        feats += _stair_features(stairs, i, key, notes)
    notes.append("walls derived from the room outlines minus door and hole rectangles")
    return feats


def _read_obstacles_only(data: dict, where: str, notes: list[str]) -> list[dict]:
    obstacles = data["obstacles"]
    if isinstance(obstacles, list):
        obstacles = {"0": obstacles}
    if not all(isinstance(v, list) for v in obstacles.values()):
        raise BuildingError(f"{where}: 'obstacles' must map floor names to lists of polygons")
    static = {"floors": {k: {"floor_meta": {"name": k, "minz_abs": i * DEFAULT_FLOOR_HEIGHT / CM},
                             "obstacles": obstacles[k]}
                         for i, k in enumerate(_floor_keys(where, obstacles))}}
    notes.append(f"obstacles-only file: floors assumed {DEFAULT_FLOOR_HEIGHT} m apart from z = 0")
    return _read_static(static, where, notes)


def _stair_features(stairs: list[tuple[str, Polygon]], floor: int, key: str,
                    notes: list[str]) -> list[dict]:
    out = []
    for name, poly in stairs:
        centre, along, long, short = _rectangle(poly)
        ends = [centre - along * (long / 2 - short / 4), centre + along * (long / 2 - short / 4)]
        ends.sort(key=lambda p: (round(p[0], 3), round(p[1], 3)))
        out.append(_feat("stair", {"type": "LineString", "coordinates": np.round(ends, 4).tolist()},
                         floor=floor, id=f"stair_{name}@{key}", floor_to=floor + 1,
                         width=round(short, 4)))
        notes.append(f"stair {name}@{key}: bottom assumed at the end nearer the origin "
                     f"({ends[0][0]:.2f}, {ends[0][1]:.2f})")
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


def parse_aamks(data: dict, *, where: str, source: Path | None = None,
                default_name: str = "aamks") -> Building:
    """Build the model from a decoded Aamks export (any of the three shapes)."""
    notes = ["Aamks units: centimetres (converted to metres)"]
    if isinstance(data.get("floors"), dict):
        feats = _read_static(data, where, notes)
    elif "obstacles" in data:
        feats = _read_obstacles_only(data, where, notes)
    else:
        feats = _read_cad(data, where, notes)
    feats += _entrances(feats)
    building = parse_geojson({"type": "FeatureCollection", "name": default_name, "features": feats},
                             where=where, source=source, default_name=default_name)
    building.notes.extend(notes)
    return building
