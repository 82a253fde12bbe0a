"""GeoJSON plans drawn in a GIS tool: positions in WGS84 or a projected CRS to plan metres.

The native plan is in plan metres. A plan drawn over a map in QGIS (or written by
``firenav map export`` from a georeferenced plan) is instead in longitude/latitude
(RFC 7946) or in a projected CRS named by a ``crs`` member. :func:`to_plan_metres`
recognises such a file (firenav's ``coordinate_frame`` member saying WGS84, or a
``crs`` member PROJ understands: ``urn:ogc:def:crs:OGC:1.3:CRS84``, ``EPSG:4326``,
``EPSG:2180``, a UTM zone...), and converts every position to plan metres with the
plan's georeference: the one the file carries (``coordinate_frame.georef`` or a
``georef`` feature's lat/lon/alt/bearing_deg, pinned to plan (0, 0)), else East-North
at the centre of the plan (noted). A file without either whose positions look like
degrees (the whole plan inside 5 cm) is refused rather than read as a tiny building.
"""
from __future__ import annotations

import copy
from typing import Any

import numpy as np

from .georef import GeoRef
from .model import BuildingError

__all__ = ["to_plan_metres"]

#: A plan without a CRS whose positions all lie within this extent [m] looks like degrees.
DEGREES_EXTENT = 0.05


def _leaves(coords: Any, out: list) -> None:
    """Collect the position lists ([x, y, ...]) of a GeoJSON coordinates array."""
    stack = [coords]
    while stack:
        c = stack.pop()
        if isinstance(c, list) and c and all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                             for v in c):
            out.append(c)
        elif isinstance(c, list):
            stack.extend(c)


def _positions(data: dict) -> list[list]:
    """Every position of the collection: geometries and stair ``footprint`` rings."""
    out: list[list] = []
    for f in data.get("features") or []:
        if not isinstance(f, dict):
            continue
        g, p = f.get("geometry"), f.get("properties")
        if isinstance(g, dict):
            _leaves(g.get("coordinates"), out)
        if isinstance(p, dict) and isinstance(p.get("footprint"), list):
            _leaves(p["footprint"], out)
    return out


def _crs_name(data: dict) -> str | None:
    crs = data.get("crs")
    if not isinstance(crs, dict):
        return None
    name = (crs.get("properties") or {}).get("name") if isinstance(crs.get("properties"), dict) else None
    return name if isinstance(name, str) else None


def _file_georef(data: dict, where: str) -> GeoRef | None:
    cf = data.get("coordinate_frame")
    g = cf.get("georef") if isinstance(cf, dict) else None
    try:
        if isinstance(g, dict):
            return GeoRef(lat=g["lat"], lon=g["lon"], bearing=g.get("bearing_deg", 0.0),
                          alt=g.get("alt_m", 0.0), anchor=tuple(g.get("anchor_xy_m", (0.0, 0.0))))
        for f in data.get("features") or []:
            p = f.get("properties") if isinstance(f, dict) else None
            if isinstance(p, dict) and p.get("kind") == "georef":
                return GeoRef(lat=p.get("lat"), lon=p.get("lon"), bearing=p.get("bearing_deg", 0.0),
                              alt=p.get("alt", 0.0))
    except (KeyError, TypeError, ValueError) as exc:
        raise BuildingError(f"{where}: the file's georeference is not usable ({exc})") from None
    return None


def to_plan_metres(data: Any, where: str) -> tuple[Any, GeoRef | None, list[str]]:
    """(the collection in plan metres, the georef to give the plan or None, notes).

    A collection in plan metres comes back as it is (same object), with no georef.
    """
    if not isinstance(data, dict):
        return data, None, []
    cf = data.get("coordinate_frame")
    wgs84 = isinstance(cf, dict) and cf.get("frame") == "WGS84"
    name = _crs_name(data)
    if not wgs84 and name is None:
        pts = _positions(data)
        if pts and not (isinstance(cf, dict) and cf.get("frame") == "local"):
            try:
                xy = np.array([p[:2] for p in pts], dtype=float)
            except (TypeError, ValueError):
                return data, None, []     # malformed: the feature checks report it
            span = np.ptp(xy, axis=0) if len(xy) else np.zeros(2)
            if (len(xy) > 2 and np.all(np.isfinite(xy)) and span.max() < DEGREES_EXTENT
                    and np.all(np.abs(xy[:, 0]) <= 180) and np.all(np.abs(xy[:, 1]) <= 90)
                    and np.abs(xy).max() > 1.0):
                raise BuildingError(f"{where}: the whole plan lies within {DEGREES_EXTENT * 100:.0f} "
                                    f"cm around ({xy[0, 0]:.6f}, {xy[0, 1]:.6f}): these look like "
                                    "longitude/latitude degrees; say so with a 'crs' member "
                                    "(e.g. urn:ogc:def:crs:OGC:1.3:CRS84) or give plan metres")
        return data, None, []
    from pyproj import CRS, Transformer
    from pyproj.exceptions import CRSError
    try:
        source = CRS.from_user_input("OGC:CRS84" if wgs84 else name)
    except CRSError:
        raise BuildingError(f"{where}: unknown crs {name!r} (give one PROJ knows, e.g. "
                            "EPSG:4326 or urn:ogc:def:crs:OGC:1.3:CRS84)") from None
    try:
        data = copy.deepcopy(data)
    except RecursionError:
        raise BuildingError(f"{where}: coordinates nested too deeply") from None
    pts = _positions(data)
    if not pts:
        return data, None, []
    try:
        raw = np.array([p[:2] for p in pts], dtype=float)
    except (TypeError, ValueError):
        raise BuildingError(f"{where}: positions must be [x, y] numbers") from None
    if not np.all(np.isfinite(raw)):
        raise BuildingError(f"{where}: geometry has NaN or infinite coordinates")
    to_lonlat = Transformer.from_crs(source, "OGC:CRS84", always_xy=True)
    lon, lat = to_lonlat.transform(raw[:, 0], raw[:, 1])
    if not (np.all(np.isfinite(lon)) and np.all(np.isfinite(lat))):
        raise BuildingError(f"{where}: some positions are outside the area of crs {source.name}")
    georef = _file_georef(data, where)
    notes = [f"positions converted from {source.name} to plan metres"]
    if georef is None:
        clon, clat = float((lon.min() + lon.max()) / 2), float((lat.min() + lat.max()) / 2)
        georef = GeoRef(lat=clat, lon=clon)
        notes.append(f"the file has no georef: plan frame East-North at lat {clat:.7f}, "
                     f"lon {clon:.7f} (its centre), height 0")
    xy = georef.from_wgs84(np.column_stack([lon, lat, np.full(len(lon), georef.alt)]))[:, :2]
    for p, (x, y) in zip(pts, np.round(xy, 6)):
        p[:] = [float(x), float(y)]
    data.pop("crs", None)
    data.pop("coordinate_frame", None)
    data["features"] = [f for f in data["features"]
                        if not (isinstance(f, dict) and (f.get("properties") or {}).get("kind") == "georef")]
    return data, georef, notes
