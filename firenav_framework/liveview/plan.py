"""The floor plan as the commander's page draws it (plan metres, x east, y north in the
plan frame): walls, doors, openings, rooms with their names, stairs with their
direction and the floors they join, entrances, anchors, and where true north is."""
from __future__ import annotations

import math
from typing import Any

import numpy as np
import shapely

__all__ = ["building_json", "north_in_plan", "true_turn"]


def _r(v: float) -> float:
    return round(float(v), 3)


def _pts(a: np.ndarray) -> list[list[float]]:
    return [[_r(x), _r(y)] for x, y in np.asarray(a, float).reshape(-1, 2)]


def _rings(geom: Any) -> list[list[list[float]]]:
    """Exterior rings of a (Multi)Polygon, each a closed list of (x, y) [m]."""
    return [_pts(np.asarray(p.exterior.coords)) for p in shapely.get_parts(geom)
            if p.geom_type == "Polygon" and not p.is_empty]


def true_turn(georef: Any) -> np.ndarray:
    """(2, 2) matrix taking plan (x, y) vectors to true (east, north) ones [m]."""
    enu = georef.plan_to_enu(np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]))
    return np.column_stack([enu[1, :2] - enu[0, :2], enu[2, :2] - enu[0, :2]])


def north_in_plan(georef: Any) -> dict:
    """Where true north points in the plan: the unit vector (x, y) and whether it is
    known. A georef's bearing (degrees clockwise from true north of plan +y) turns plan
    +y away from north, so north is plan +y turned back by it: (-sin b, cos b). Without
    a georef the plan's +y is shown as 'plan north'."""
    if georef is None:
        return {"x": 0.0, "y": 1.0, "true": False}
    b = math.radians(georef.bearing)
    return {"x": _r(-math.sin(b)), "y": _r(math.cos(b)), "true": True}


def building_json(building: Any) -> dict:
    """Everything of a building model the page draws (see the module docstring)."""
    if building is None:
        return {"name": "", "floors": [], "north": north_in_plan(None), "georef": None}
    floors = []
    for f in building.floors:
        walls = f.walls[~f.wall_is_obstacle] if len(f.walls) else f.walls
        rooms = []
        for room in f.rooms:
            c = room.polygon.representative_point()
            rooms.append({"id": room.id, "name": room.name or "", "use": room.use,
                          "rings": _rings(room.polygon), "label": [_r(c.x), _r(c.y)]})
        stairs = [{"id": s.id, "from": s.floor_from, "to": s.floor_to, "path": _pts(s.path),
                   "rings": _rings(s.polygon), "arrives": False} for s in f.stairs]
        stairs += [{"id": s.id, "from": s.floor_from, "to": s.floor_to, "path": _pts(s.path),
                    "rings": _rings(s.polygon), "arrives": True}
                   for s in building.stairs if s.floor_to == f.index]
        floors.append({
            "index": f.index, "name": f.name or f"floor {f.index}", "z": _r(f.z),
            "walls": [_pts(seg) for seg in walls],
            "doors": [{"id": d.id, "jambs": _pts(d.jambs)} for d in f.doors],
            "openings": [{"id": d.id, "jambs": _pts(d.jambs)} for d in f.openings],
            "obstacles": [r for o in f.obstacles for r in _rings(o.polygon)],
            "rooms": rooms, "stairs": stairs,
            "entrances": [{"id": e.id, "position": _pts(e.position)[0],
                           "heading": _r(e.heading)}
                          for e in building.entrances if e.floor == f.index],
            "anchors": [{"id": a.id, "kind": a.kind, "position": _pts(a.position[:2])[0]}
                        for a in building.anchors if a.floor == f.index],
        })
    georef = building.georef
    return {"name": getattr(building, "name", ""), "floors": floors,
            "north": north_in_plan(georef),
            "georef": georef.describe() if georef is not None else None}
