"""Draw plans in code: rooms as polygons, walls derived from their outlines, doors cut in.

Used to author the bundled plans and by tests that need a small building without a file.
Walls are the union of every room outline plus any extra walls, with shared edges drawn
once; each door and opening then cuts its gap out of the walls it sits on. The result is
a native GeoJSON plan (:meth:`PlanSketch.geojson`) or the model itself (:meth:`build`).
"""
from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Sequence

import numpy as np
import shapely
from shapely.geometry import LineString, Polygon, box

from .geojson_format import dump_plan, parse_geojson
from .model import Building

__all__ = ["PlanSketch", "FloorSketch"]

Point = tuple[float, float]
#: Width of an interior door [m] where a sketch does not say.
INTERIOR_DOOR = 0.9


def _r(v) -> list:
    return np.round(np.asarray(v, dtype=float), 4).tolist()


class FloorSketch:
    """The features of one floor while it is being drawn (coordinates in metres)."""

    def __init__(self, index: int, z: float, height: float, name: str):
        self.index, self.z, self.height, self.name = index, z, height, name
        self.rooms: list[tuple[str, Polygon, str, str]] = []
        self.extra_walls: list[LineString] = []
        self.gaps: list[tuple[str, str, np.ndarray]] = []   # (kind, id, jambs (2, 2))
        self.stairs: list[dict] = []
        self.obstacles: list[tuple[str, Polygon]] = []

    def room(self, id: str, shape: Sequence[Point] | tuple[float, float, float, float],
             name: str = "", use: str = "room", holes: Sequence[Sequence[Point]] = ()) -> "FloorSketch":
        """A room from a box (x0, y0, x1, y1) or a polygon's vertex list; its outline is walled."""
        poly = _polygon(shape) if not holes else Polygon(shape, holes)
        self.rooms.append((id, poly, name, use))
        return self

    def room_row(self, prefix: str, xs: Sequence[float], y0: float, y1: float, label: str,
                 door_at: float | None = None, door_y: float | None = None) -> "FloorSketch":
        """Rooms side by side between consecutive ``xs`` [m], from ``y0`` to ``y1``: ids
        ``<prefix>1, <prefix>2, ...``, names ``<label>1, ...``. With ``door_at``, each has a
        door ``d_<prefix>k`` in its wall at ``door_y``, crossed north-south, centred
        ``door_at`` metres from the room's west end (>= 0) or its east end (< 0)."""
        for k, (x0, x1) in enumerate(zip(xs, xs[1:]), 1):
            self.room(f"{prefix}{k}", (x0, y0, x1, y1), f"{label}{k}")
            if door_at is not None:
                x = x0 + door_at if door_at >= 0 else x1 + door_at
                self.door(f"d_{prefix}{k}", (x, y1 if door_y is None else door_y), INTERIOR_DOOR,
                          (0.0, 1.0))
        return self

    def wall(self, *points: Point) -> "FloorSketch":
        """An extra wall polyline (walls along room outlines come for free)."""
        self.extra_walls.append(LineString(points))
        return self

    def door(self, id: str, center: Point, width: float, axis: Point,
             kind: str = "door") -> "FloorSketch":
        """A door of ``width`` [m] centred on a wall; ``axis`` is the crossing direction."""
        a = np.asarray(axis, dtype=float) / math.hypot(*axis)
        along = np.array([a[1], -a[0]]) * width / 2
        c = np.asarray(center, dtype=float)
        self.gaps.append((kind, id, np.array([c - along, c + along])))
        return self

    def opening(self, id: str, center: Point, width: float, axis: Point) -> "FloorSketch":
        """A doorless gap (open-plan passage) in a wall."""
        return self.door(id, center, width, axis, kind="opening")

    def stair(self, id: str, path: Sequence[Point], floor_to: int, width: float = 1.0,
              n_steps: int | None = None) -> "FloorSketch":
        """A stair from this floor: ``path`` is the walking line from bottom to top."""
        props = {"floor_to": floor_to, "width": width}
        if n_steps:
            props["n_steps"] = n_steps
        self.stairs.append({"id": id, "path": path, **props})
        return self

    def obstacle(self, id: str, shape: tuple[float, float, float, float] | Sequence[Point]) -> "FloorSketch":
        """Furniture or another fixed obstacle: a box (x0, y0, x1, y1) or a polygon."""
        self.obstacles.append((id, _polygon(shape)))
        return self

    def wall_lines(self) -> list[LineString]:
        """Walls: the room outlines and extra walls, noded and merged, minus the gaps."""
        lines: list = [LineString(r) for _, p, _, _ in self.rooms
                       for r in [p.exterior, *p.interiors]]
        lines += self.extra_walls
        if not lines:
            return []
        walls = shapely.union_all(lines)
        if self.gaps:
            cutters = [LineString(j).buffer(0.05, cap_style="flat") for _, _, j in self.gaps]
            walls = walls.difference(shapely.union_all(cutters))
        merged = shapely.line_merge(walls)
        parts = [shapely.simplify(g, 0.0) for g in shapely.get_parts(merged)]
        return sorted((g for g in parts if g.length > 1e-6),
                      key=lambda g: (round(g.coords[0][1], 4), round(g.coords[0][0], 4)))

    def features(self) -> list[dict]:
        f = self.index
        out = [_feat("floor", None, floor=f, z=self.z, height=self.height, name=self.name)]
        for k, line in enumerate(self.wall_lines()):
            out.append(_feat("wall", {"type": "LineString", "coordinates": _r(line.coords)},
                             floor=f, id=f"w{f}_{k + 1}"))
        for kind, id, jambs in self.gaps:
            out.append(_feat(kind, {"type": "LineString", "coordinates": _r(jambs)}, floor=f, id=id))
        for id, poly, name, use in self.rooms:
            out.append(_feat("room", json.loads(shapely.to_geojson(poly)), floor=f, id=id,
                             name=name, use=use))
        for s in self.stairs:
            s = dict(s)
            path = s.pop("path")
            out.append(_feat("stair", {"type": "LineString", "coordinates": _r(path)}, floor=f, **s))
        for id, poly in self.obstacles:
            out.append(_feat("obstacle", json.loads(shapely.to_geojson(poly)), floor=f, id=id))
        return out


def _polygon(shape) -> Polygon:
    """A box from (x0, y0, x1, y1), else a polygon from its vertex list."""
    if len(shape) == 4 and all(isinstance(v, (int, float)) for v in shape):
        return box(*shape)
    return Polygon(shape)


def _feat(kind: str, geometry: dict | None, **props) -> dict:
    return {"type": "Feature", "properties": {"kind": kind, **props}, "geometry": geometry}


class PlanSketch:
    """A building drawn in code. ``floor()`` adds storeys bottom-up (index 0 first)."""

    def __init__(self, name: str):
        self.name = name
        self.floors: list[FloorSketch] = []
        self.extra: list[dict] = []

    def floor(self, z: float, height: float, name: str = "") -> FloorSketch:
        fs = FloorSketch(len(self.floors), z, height, name or str(len(self.floors)))
        self.floors.append(fs)
        return fs

    def storeys(self, height: float, names: Sequence[str]) -> list[FloorSketch]:
        """One storey per name, bottom-up, ``height`` [m] floor to floor, the first at
        z = 0 (a building of equal storeys)."""
        return [self.floor(height * level, height, name) for level, name in enumerate(names)]

    def base_station(self, xy: Point, height: float = 1.0) -> "PlanSketch":
        """The incident's base station: anchor ``base`` (kind ``base_station``), ``height``
        [m] above the ground floor at ``xy``."""
        return self.anchor("base", xy, height=height, kind="base_station")

    def anchor(self, id: str, xy: Point, floor: int = 0, height: float = 0.0,
               kind: str = "uwb") -> "PlanSketch":
        """A fixed radio node ``height`` [m] above the floor level."""
        self.extra.append(_feat("anchor", {"type": "Point", "coordinates": _r(xy)}, floor=floor,
                                id=id, anchor_kind=kind, height=height))
        return self

    def entrance(self, id: str, xy: Point, floor: int = 0, heading_deg: float | None = None,
                 door: str | None = None) -> "PlanSketch":
        props: dict = {"floor": floor, "id": id}
        if heading_deg is not None:
            props["heading_deg"] = heading_deg
        if door is not None:
            props["door"] = door
        self.extra.append(_feat("entrance", {"type": "Point", "coordinates": _r(xy)}, **props))
        return self

    def georef(self, lat: float, lon: float, bearing_deg: float = 0.0,
               at: Point = (0.0, 0.0)) -> "PlanSketch":
        self.extra.append(_feat("georef", {"type": "Point", "coordinates": _r(at)}, lat=lat,
                                lon=lon, bearing_deg=bearing_deg))
        return self

    def geojson(self) -> dict:
        feats = [f for fs in self.floors for f in fs.features()] + self.extra
        return {"type": "FeatureCollection", "name": self.name, "features": feats}

    def build(self) -> Building:
        return parse_geojson(self.geojson(), where=f"<sketch {self.name}>", default_name=self.name)

    def write(self, path: str | Path) -> None:
        Path(path).write_text(dump_plan(self.geojson()), encoding="utf-8")
