"""DXF plan import (ezdxf): layers mapped to walls, doors, rooms, stairs by a YAML table.

The table (``data/dxf_layers.yaml`` is the built-in default and documents every key)
gives the drawing unit, a layer prefix naming the floor, floor levels, and shell
patterns of layer names per feature kind. Entities on unmapped layers are ignored;
entities of a kind the importer cannot use on a mapped layer are counted in
``Building.notes``, and so are walls drawn twice (merged into one). Coordinates, floor
numbers and arc flattening are bounded by :mod:`.limits`. Features get ids ``<kind><floor>_<DXF handle>`` so that an error
or a ``map check`` problem points at the entity in the CAD program.
"""
from __future__ import annotations

import fnmatch
import math
import re
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator
from shapely.geometry import Polygon

from .aamks import door_feature_from_rectangle
from .bundled import DATA_DIR
from .geojson_format import DEFAULT_FLOOR_HEIGHT, parse_geojson
from .limits import (MAX_ARC_SEGMENTS, MAX_FEATURES, MAX_FLOORS, MAX_VERTICES,
                     check_coordinates, check_count)
from ..yaml_locations import ConfigError
from ..yaml_locations import load as load_yaml
from .model import Building, BuildingError

__all__ = ["read_dxf", "LayerMap", "DEFAULT_LAYER_MAP"]

DEFAULT_LAYER_MAP = DATA_DIR / "dxf_layers.yaml"
_UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001, "ft": 0.3048, "in": 0.0254}
_KINDS = ("wall", "door", "opening", "room", "stair", "obstacle", "anchor", "entrance")
ARC_SAGITTA = 0.05   # [m] largest gap between an arc and its flattened wall segments


class FloorLevel(BaseModel):
    model_config = ConfigDict(extra="forbid")
    z: float
    height: float = Field(DEFAULT_FLOOR_HEIGHT, gt=0)
    name: str = ""


class LayerMap(BaseModel):
    """The layer table (see ``data/dxf_layers.yaml``)."""

    model_config = ConfigDict(extra="forbid")
    unit: str = "auto"
    floor_pattern: str | None = None
    floors: list[FloorLevel] = []
    layers: dict[str, list[str]]
    stair_width: float = Field(1.0, gt=0)
    anchor_height: float = 1.0

    @field_validator("unit")
    @classmethod
    def _unit(cls, v: str) -> str:
        if v != "auto" and v not in _UNITS:
            raise ValueError(f"unit must be auto or one of {', '.join(_UNITS)}")
        return v

    @field_validator("floor_pattern")
    @classmethod
    def _pattern(cls, v: str | None) -> str | None:
        if v is not None:
            try:
                rx = re.compile(v)
            except re.error as exc:
                raise ValueError(f"not a regular expression: {exc}") from None
            if "floor" not in rx.groupindex:
                raise ValueError("needs a named group (?P<floor>...)")
        return v

    @field_validator("layers")
    @classmethod
    def _kinds(cls, v: dict[str, list[str]]) -> dict[str, list[str]]:
        bad = set(v) - set(_KINDS)
        if bad:
            raise ValueError(f"unknown feature kind(s) {sorted(bad)}; use {', '.join(_KINDS)}")
        return v

    def classify(self, layer: str) -> tuple[str | None, int]:
        """(feature kind or None, floor index) of a layer name."""
        floor, rest = 0, layer
        if self.floor_pattern:
            m = re.match(self.floor_pattern, layer, flags=re.IGNORECASE)
            if m:
                floor, rest = int(m.group("floor")), layer[m.end():]
        for kind, patterns in self.layers.items():
            if any(fnmatch.fnmatchcase(rest.upper(), p.upper()) for p in patterns):
                return kind, floor
        return None, floor


def load_layer_map(path: Path) -> LayerMap:
    """The layer map in ``path``, read with the pipeline files' limits (size, alias
    expansion, nesting: :mod:`..yaml_locations`)."""
    try:
        data = load_yaml(path).data
    except ConfigError as exc:
        raise BuildingError(f"layer map: {'; '.join(map(str, exc.problems))}") from None
    try:
        return LayerMap.model_validate(data if data is not None else {})
    except ValidationError as exc:
        errs = "; ".join(f"{'.'.join(map(str, e['loc'])) or 'top level'}: {e['msg']}"
                         for e in exc.errors())
        raise BuildingError(f"{path}: invalid layer map: {errs}") from None


def _feat(kind: str, geometry: dict | None, **props) -> dict:
    return {"type": "Feature", "properties": {"kind": kind, **props}, "geometry": geometry}


def _xy(points: Any, scale: float) -> np.ndarray:
    return np.array([[p[0], p[1]] for p in points], dtype=float).reshape(-1, 2) * scale


def _arc_points(centre: np.ndarray, radius: float, a0: float, a1: float,
                notes: Counter[str]) -> np.ndarray:
    """Points [m] of a counter-clockwise arc from angle ``a0`` to ``a1`` [rad], within
    ``ARC_SAGITTA`` of the curve but in at most ``MAX_ARC_SEGMENTS`` pieces (counted in
    ``notes`` when that makes them coarser)."""
    sweep = (a1 - a0) % (2 * math.pi) or 2 * math.pi
    if radius <= ARC_SAGITTA:
        n = 1
    else:
        n = math.ceil(sweep / (2 * math.acos(1 - ARC_SAGITTA / radius)))
    if n > MAX_ARC_SEGMENTS:
        notes[f"arcs flattened coarser than {ARC_SAGITTA} m to stay within "
              f"{MAX_ARC_SEGMENTS} pieces each"] += 1
        n = MAX_ARC_SEGMENTS
    ang = a0 + np.linspace(0.0, sweep, n + 1)
    return centre + radius * np.column_stack([np.cos(ang), np.sin(ang)])


def _bulged(pts: np.ndarray, bulges: np.ndarray, closed: bool, where: str,
            notes: Counter[str]) -> np.ndarray:
    """A polyline's vertices (K, 2) [m] with each bulged edge replaced by its arc."""
    from ezdxf.math import bulge_to_arc

    if not np.any(bulges):
        return pts
    ends = np.vstack([pts, pts[:1]]) if closed else pts
    out = [pts[:1]]
    for k in range(len(ends) - 1):
        a, b, bulge = ends[k], ends[k + 1], float(bulges[k])
        if bulge == 0.0 or not np.any(a != b):
            out.append(ends[k + 1:k + 2])
            continue
        centre, sa, ea, radius = bulge_to_arc(a, b, bulge)
        centre = np.array([centre.x, centre.y])
        check_coordinates(where, np.array([centre - radius, centre + radius]))
        arc = _arc_points(centre, radius, sa, ea, notes)
        if bulge < 0:          # clockwise: bulge_to_arc gives the arc from b to a
            arc = arc[::-1]
        out.append(arc[1:])
        check_count(where, "vertices after flattening its arcs", sum(map(len, out)),
                    MAX_VERTICES)
    got = np.vstack(out)
    return got[:-1] if closed else got


def _vertices(e: Any, scale: float, where: str, notes: Counter[str]
              ) -> tuple[np.ndarray, bool] | None:
    """(points (K, 2) [m], closed) of a linear entity, or None if it is not one. Arcs and
    polyline bulges are flattened to within ``ARC_SAGITTA`` (at most ``MAX_ARC_SEGMENTS``
    pieces per arc); coordinates are checked against the plan limits first."""
    t = e.dxftype()
    if t == "LINE":
        pts = _xy([e.dxf.start, e.dxf.end], scale)
        check_coordinates(where, pts)
        return pts, False
    if t == "ARC":
        centre = _xy([e.dxf.center], scale)[0]
        radius = float(e.dxf.radius) * scale
        check_coordinates(where, np.array([centre - abs(radius), centre + abs(radius)]))
        if not radius > 0:
            return None
        return _arc_points(centre, radius, math.radians(e.dxf.start_angle),
                           math.radians(e.dxf.end_angle), notes), False
    if t == "LWPOLYLINE":
        check_count(where, "vertices", len(e), MAX_VERTICES)
        raw = np.array(list(e.get_points("xyb")), dtype=float).reshape(-1, 3)
        closed = bool(e.closed)
    elif t == "POLYLINE" and e.is_2d_polyline:
        check_count(where, "vertices", len(e.vertices), MAX_VERTICES)
        raw = np.array([(v.dxf.location[0], v.dxf.location[1], v.dxf.bulge)
                        for v in e.vertices], dtype=float).reshape(-1, 3)
        closed = bool(e.is_closed)
    else:
        return None
    pts = raw[:, :2] * scale
    check_coordinates(where, pts)
    if not np.all(np.isfinite(raw[:, 2])):
        raise BuildingError(f"{where}: polyline bulge values are not finite")
    pts = _bulged(pts, raw[:, 2], closed, where, notes)
    if closed and len(pts) > 1 and np.allclose(pts[0], pts[-1]):
        pts = pts[:-1]
    return pts, closed


def _point(e: Any, scale: float, where: str) -> np.ndarray | None:
    t = e.dxftype()
    if t == "POINT":
        p = _xy([e.dxf.location], scale)
    elif t == "CIRCLE":
        p = _xy([e.dxf.center], scale)
    else:
        return None
    check_coordinates(where, p)
    return p[0]


def read_dxf(path: str | Path, layer_map: str | Path | None = None) -> Building:
    """Load a DXF plan with a layer map: ``layer_map``, else ``<plan>.layers.yaml`` beside
    the drawing, else the built-in table."""
    import ezdxf

    path = Path(path)
    if layer_map is not None:
        map_path = Path(layer_map)
    else:
        sidecar = path.with_suffix(".layers.yaml")
        map_path = sidecar if sidecar.is_file() else DEFAULT_LAYER_MAP
    table = load_layer_map(map_path)
    try:
        doc = ezdxf.readfile(path)
    except (OSError, ezdxf.DXFError) as exc:
        raise BuildingError(f"{path}: cannot read the DXF drawing ({exc})") from None
    if table.unit == "auto":
        insunits = int(doc.header.get("$INSUNITS", 0))
        scale = 1.0 if insunits == 0 else ezdxf.units.conversion_factor(insunits, ezdxf.units.M)
        unit_note = (f"DXF unit: {ezdxf.units.unit_name(insunits)} ($INSUNITS {insunits})"
                     if insunits else "DXF unit: none in the header, taken as metres")
    else:
        scale = _UNITS[table.unit]
        unit_note = f"DXF unit: {table.unit} (from the layer map)"
    notes = [f"layer map: {map_path}", unit_note]
    skipped: Counter[str] = Counter()
    feats: list[dict] = []
    floors_used: set[int] = set()
    layers_seen: set[str] = set()
    for e in doc.modelspace():
        layers_seen.add(e.dxf.layer)
        kind, floor = table.classify(e.dxf.layer)
        if kind is None:
            continue
        where = f"{path}: entity {e.dxf.handle} ({e.dxftype()} on layer {e.dxf.layer})"
        if floor >= MAX_FLOORS:
            raise BuildingError(f"{where}: the layer name puts it on floor {floor}; a "
                                f"building has at most {MAX_FLOORS} floors (check the layer "
                                "names and the floor_pattern of the layer map)")
        floors_used.add(floor)
        check_count(str(path), "entities on mapped layers", len(feats) + 1, MAX_FEATURES)
        ident = f"{kind}{floor}_{e.dxf.handle}"
        feat = _entity_feature(e, kind, floor, ident, scale, table, where, skipped)
        if feat is None:
            skipped[f"skipped {e.dxftype()} on {kind} layers (not usable)"] += 1
        else:
            feats.append(feat)
    if not floors_used:
        raise BuildingError(f"{path}: no entity on any mapped layer (layer map {map_path}); "
                            f"layers used in the drawing: {', '.join(sorted(layers_seen)) or 'none'}")
    n = max(floors_used) + 1
    if min(floors_used) < 0:
        raise BuildingError(f"{path}: negative floor index in a layer name; number floors from 0")
    for i in range(n):
        level = table.floors[i] if i < len(table.floors) else FloorLevel(z=i * DEFAULT_FLOOR_HEIGHT)
        feats.insert(i, _feat("floor", None, floor=i, z=level.z, height=level.height,
                              name=level.name or str(i)))
    notes += [f"{what}: {count}" for what, count in sorted(skipped.items())]
    building = parse_geojson({"type": "FeatureCollection", "name": path.stem, "features": feats},
                             where=str(path), source=path, default_name=path.stem,
                             merge_walls=True)
    building.notes[:0] = notes
    return building


def _entity_feature(e: Any, kind: str, floor: int, ident: str, scale: float,
                    table: LayerMap, where: str, notes: Counter[str]) -> dict | None:
    if kind in ("anchor", "entrance"):
        p = _point(e, scale, where)
        if p is not None:
            props = {"floor": floor, "id": ident}
            if kind == "anchor":
                props |= {"anchor_kind": "uwb", "height": table.anchor_height}
            return _feat(kind, {"type": "Point", "coordinates": p.tolist()}, **props)
        if kind == "entrance" and e.dxftype() == "LINE":
            a, b = _vertices(e, scale, where, notes)[0]
            heading = math.degrees(math.atan2(b[1] - a[1], b[0] - a[0]))
            return _feat(kind, {"type": "Point", "coordinates": a.tolist()}, floor=floor,
                         id=ident, heading_deg=heading)
        return None
    got = _vertices(e, scale, where, notes)
    if got is None:
        return None
    pts, closed = got
    if kind == "wall":
        if closed:
            pts = np.vstack([pts, pts[:1]])
        return _feat("wall", {"type": "LineString", "coordinates": pts.tolist()}, floor=floor, id=ident)
    if kind in ("door", "opening"):
        if len(pts) == 2 and not closed:
            return _feat(kind, {"type": "LineString", "coordinates": pts.tolist()}, floor=floor, id=ident)
        if closed and len(pts) >= 4:
            return door_feature_from_rectangle(kind, ident, floor, Polygon(pts))
        raise BuildingError(f"{where}: a {kind} must be a LINE from jamb to jamb or a closed "
                            f"rectangle, got {len(pts)} points {'closed' if closed else 'open'}")
    if kind in ("room", "obstacle"):
        if not closed and not (len(pts) > 3 and np.allclose(pts[0], pts[-1])):
            raise BuildingError(f"{where}: a {kind} must be a closed polyline")
        ring = np.vstack([pts, pts[:1]]).tolist()
        return _feat(kind, {"type": "Polygon", "coordinates": [ring]}, floor=floor, id=ident)
    if kind == "stair":
        if closed:
            return None     # a footprint outline: the walking line is what defines a stair
        return _feat("stair", {"type": "LineString", "coordinates": pts.tolist()}, floor=floor,
                     id=ident, floor_to=floor + 1, width=table.stair_width)
    return None
