"""A plan as GeoJSON for GIS tools (QGIS, web maps): ``firenav map export``.

With a georeference the document follows RFC 7946: WGS84 positions [longitude,
latitude, ellipsoidal height] (the height is the georef's ``alt`` plus the floor level,
plus an anchor's height above it), exterior rings counter-clockwise, no ``crs``
member. Without one the positions are plan metres [x, y, z] and the top-level
``coordinate_frame`` member says so, since a tool assuming RFC 7946 would place them
off the coast of Africa. Every feature carries ``kind``, ``floor``, ``level_m`` and its
``id``, plus the native properties (floor ``z``/``height``, room ``name``/``use``, stair
``floor_to``/``width``/``n_steps``, ...); a stair is its walking line, its footprint a
``stair_footprint`` feature. The file loads back as a plan (:mod:`.crs_input` converts
the positions), so it can be edited in a GIS tool; the native plan stays in plan metres.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry
from shapely.geometry.polygon import orient

from .geojson_format import dump_plan
from .georef import coordinate_frame
from .model import Building

__all__ = ["gis_geojson", "write_gis_geojson"]


def gis_geojson(building: Building) -> dict:
    """The plan as one FeatureCollection (see the module docstring)."""
    geo = building.georef

    def positions(xy: np.ndarray, z: float) -> list:
        p = np.column_stack([np.asarray(xy, float).reshape(-1, 2), np.full(len(xy), z)])
        if geo is None:
            return np.round(p, 4).tolist()
        w = geo.to_wgs84(p)
        return [[round(float(a), 9), round(float(b), 9), round(float(h), 3)] for a, b, h in w]

    def geometry(g: BaseGeometry, z: float) -> dict:
        if g.geom_type == "Polygon":
            g = orient(g, 1.0)
            return {"type": "Polygon", "coordinates": [positions(np.asarray(r.coords), z)
                                                       for r in (g.exterior, *g.interiors)]}
        if g.geom_type == "MultiPolygon":
            return {"type": "MultiPolygon", "coordinates": [
                geometry(p, z)["coordinates"] for p in g.geoms]}
        if g.geom_type == "Point":
            return {"type": "Point", "coordinates": positions(np.asarray(g.coords), z)[0]}
        return {"type": "LineString", "coordinates": positions(np.asarray(g.coords), z)}

    feats = []

    def add(kind: str, g: BaseGeometry, floor: int, level: float, **props) -> None:
        feats.append({"type": "Feature", "geometry": geometry(g, level),
                      "properties": {"kind": kind, "floor": floor, "level_m": level, **props}})

    for fl in building.floors:
        if not fl.outline.is_empty:
            add("floor", fl.outline, fl.index, fl.z, name=fl.name, z=fl.z, height=fl.height)
        for r in fl.rooms:
            add("room", r.polygon, fl.index, fl.z, id=r.id, name=r.name, use=r.use)
        drawn = ~fl.wall_is_obstacle
        for wid in dict.fromkeys(np.asarray(fl.wall_ids, dtype=object)[drawn]):
            segs = fl.walls[drawn][np.asarray(fl.wall_ids, dtype=object)[drawn] == wid]
            merged = shapely.line_merge(shapely.multilinestrings(segs))
            for part in shapely.get_parts(merged):
                add("wall", part, fl.index, fl.z, id=wid)
        for d in fl.doors + fl.openings:
            add(d.kind, shapely.linestrings(d.jambs), fl.index, fl.z, id=d.id,
                width_m=round(d.width, 3))
        for o in fl.obstacles:
            add("obstacle", o.polygon, fl.index, fl.z, id=o.id)
        for s in fl.stairs:
            add("stair", shapely.linestrings(s.path), fl.index, fl.z, id=s.id,
                floor_to=s.floor_to, n_steps=s.n_steps, width=s.width)
            add("stair_footprint", s.polygon, fl.index, fl.z, id=s.id, floor_to=s.floor_to)
    for a in building.anchors:
        add("anchor", shapely.points(a.position[:2]), a.floor, float(a.position[2]), id=a.id,
            anchor_kind=a.kind, height=round(float(a.position[2] - building.floor(a.floor).z), 4))
    for e in building.entrances:
        add("entrance", shapely.points(e.position), e.floor, building.floor(e.floor).z, id=e.id,
            door=e.door, heading_deg=round(float(np.degrees(e.heading)), 2),
            **({} if geo is None else {"azimuth_deg": round(float(np.degrees(
                geo.heading_to_azimuth(e.heading))), 2)}))
    return {"type": "FeatureCollection", "name": building.name,
            "coordinate_frame": coordinate_frame(geo), "features": feats}


def write_gis_geojson(building: Building, path: str | Path) -> None:
    """Write :func:`gis_geojson` of ``building`` to ``path`` (one feature per line)."""
    Path(path).write_text(dump_plan(gis_geojson(building)), encoding="utf-8")
