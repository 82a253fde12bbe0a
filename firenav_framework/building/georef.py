"""Geographic reference of a building: local plan metres <-> WGS84 longitude, latitude, height.

The plan frame is local and level: x, y horizontal [m], z up, origin at the building
origin. A :class:`GeoRef` pins one plan point (``anchor``, usually the origin) to a
WGS84 position (``lat``, ``lon`` [deg], ``alt`` [m], the ellipsoidal height of plan
z = 0 there) and says how the plan is turned: its +y axis points ``bearing`` degrees
clockwise from true north (bearing 0: +y north and +x east, i.e. exactly ENU).

Conversions go through the local tangent plane (East-North-Up) at the anchor with PROJ
(pyproj ``topocentric`` and ``cart`` on the WGS84 ellipsoid), so they are exact for
any building size. :func:`fit_control_points` finds the georef from surveyed points.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

__all__ = ["GeoRef", "ControlFit", "fit_control_points", "LOCAL_FRAME", "WGS84_FRAME",
           "coordinate_frame"]

#: What a GeoJSON document written by firenav says about its coordinates (the top-level
#: ``coordinate_frame`` member), with and without a georeference.
WGS84_FRAME = {"frame": "WGS84", "standard": "RFC 7946",
               "order": "longitude [deg], latitude [deg], ellipsoidal height [m]"}
LOCAL_FRAME = {"frame": "local", "unit": "m",
               "order": "plan x, plan y, height above the plan origin [m]",
               "note": "NOT WGS84 longitude/latitude: these are metres from the building "
                       "origin, and a GIS tool that assumes RFC 7946 will misplace them; "
                       "give the plan a georeference (firenav map georef) to get WGS84"}


def coordinate_frame(georef: "GeoRef | None") -> dict:
    """The ``coordinate_frame`` member for GeoJSON written with (or without) ``georef``."""
    if georef is None:
        return dict(LOCAL_FRAME)
    return {**WGS84_FRAME, "georef": georef.describe()}


@dataclass(frozen=True)
class GeoRef:
    """Where the plan is on Earth and how it is turned.

    ``lat``, ``lon``: WGS84 degrees of plan point ``anchor`` (x, y) [m] (default the
    origin); ``alt``: ellipsoidal height [m] of plan z = 0 there; ``bearing``: degrees
    clockwise from true north of the plan's +y axis (0 = plan north is true north).
    """

    lat: float
    lon: float
    bearing: float = 0.0
    alt: float = 0.0
    anchor: tuple[float, float] = (0.0, 0.0)

    def __post_init__(self) -> None:
        for name, value, lim in (("lat", self.lat, 90.0), ("lon", self.lon, 180.0),
                                 ("bearing", self.bearing, 360.0), ("alt", self.alt, 1.0e5)):
            if isinstance(value, bool) or not (isinstance(value, (int, float))
                                               and math.isfinite(value) and abs(value) <= lim):
                raise ValueError(f"georef {name} must be a number within +-{lim:g}, got {value!r}")
        if not (len(self.anchor) == 2 and all(math.isfinite(float(v)) for v in self.anchor)):
            raise ValueError(f"georef anchor must be a plan point (x, y), got {self.anchor!r}")

    # ------------------------------------------------------------------ PROJ pipelines

    @cached_property
    def _enu_to_geodetic(self):
        from pyproj import Transformer
        return Transformer.from_pipeline(
            f"+proj=pipeline +step +inv +proj=topocentric +ellps=WGS84 +lat_0={self.lat!r} "
            f"+lon_0={self.lon!r} +h_0={self.alt!r} +step +inv +proj=cart +ellps=WGS84 "
            "+step +proj=unitconvert +xy_in=rad +xy_out=deg")

    def _rotation(self) -> np.ndarray:
        """Matrix taking plan (x, y) to true (east, north)."""
        b = math.radians(self.bearing)
        return np.array([[math.cos(b), math.sin(b)], [-math.sin(b), math.cos(b)]])

    # ------------------------------------------------------------------ conversions

    def plan_to_enu(self, xyz: np.ndarray) -> np.ndarray:
        """Plan points (N, 2 or 3) [m] -> East-North-Up (N, 3) [m] at the anchor."""
        p = np.atleast_2d(np.asarray(xyz, dtype=float))
        z = p[:, 2] if p.shape[1] > 2 else np.zeros(len(p))
        en = (p[:, :2] - np.asarray(self.anchor, float)) @ self._rotation().T
        return np.column_stack([en, z])

    def to_wgs84(self, xyz: np.ndarray) -> np.ndarray:
        """Plan points (N, 2 or 3) [m] -> (N, 3) longitude, latitude [deg], ellipsoidal
        height [m] (GeoJSON order); a missing z is the plan origin's level."""
        enu = self.plan_to_enu(xyz)
        lon, lat, h = self._enu_to_geodetic.transform(enu[:, 0], enu[:, 1], enu[:, 2])
        return np.column_stack([lon, lat, h])

    def from_wgs84(self, lonlath: np.ndarray) -> np.ndarray:
        """(N, 2 or 3) longitude, latitude [deg], ellipsoidal height [m] -> plan (N, 3) [m]."""
        q = np.atleast_2d(np.asarray(lonlath, dtype=float))
        h = q[:, 2] if q.shape[1] > 2 else np.full(len(q), self.alt)
        from pyproj.enums import TransformDirection
        e, n, u = self._enu_to_geodetic.transform(q[:, 0], q[:, 1], h,
                                                  direction=TransformDirection.INVERSE)
        xy = np.column_stack([e, n]) @ self._rotation() + np.asarray(self.anchor, float)
        return np.column_stack([xy, u])

    def to_lonlat(self, xy: np.ndarray) -> np.ndarray:
        """Plan points (N, 2) [m] -> (N, 2) [lon, lat] degrees (GeoJSON order)."""
        return self.to_wgs84(np.asarray(xy, float).reshape(-1, 2))[:, :2]

    def from_lonlat(self, lonlat: np.ndarray) -> np.ndarray:
        """(N, 2) [lon, lat] degrees -> plan points (N, 2) [m] (at the anchor's height)."""
        return self.from_wgs84(np.asarray(lonlat, float).reshape(-1, 2))[:, :2]

    def heading_to_azimuth(self, heading: np.ndarray | float) -> np.ndarray | float:
        """Plan heading [rad, CCW from +x] -> compass azimuth [rad, clockwise from true north]."""
        return np.mod(np.pi / 2 - np.asarray(heading) + math.radians(self.bearing), 2 * np.pi)

    def describe(self) -> dict:
        """The georef as plain numbers (for files and messages)."""
        return {"lat": self.lat, "lon": self.lon, "alt_m": self.alt,
                "bearing_deg": self.bearing, "anchor_xy_m": list(map(float, self.anchor))}

    @classmethod
    def at_point(cls, xy: tuple[float, float], lat: float, lon: float,
                 bearing: float = 0.0, alt: float = 0.0) -> "GeoRef":
        """The georef whose plan point ``xy`` [m] lies at (lat, lon, alt)."""
        return cls(lat=lat, lon=lon, bearing=bearing, alt=alt,
                   anchor=(float(xy[0]), float(xy[1])))


@dataclass(frozen=True)
class ControlFit:
    """A georef fitted to control points, with what the fit leaves: ``residuals`` (N,)
    [m] horizontal distance between each point's plan position and its surveyed one,
    and ``scale``, the plan-to-ground scale a fit allowed to stretch would choose (1.0 for
    a plan drawn true to scale)."""

    georef: GeoRef
    residuals: np.ndarray
    scale: float


def fit_control_points(plan_xy: np.ndarray, lonlat: np.ndarray, alt: float = 0.0) -> ControlFit:
    """The rigid turn and shift (no stretch) that best puts plan points (N, 2) [m] on
    their surveyed WGS84 positions (N, 2) [lon, lat deg], N >= 2 (least squares).

    The points are taken into the tangent plane at their surveyed centroid, where the
    2-D Procrustes (Kabsch) solution gives the rotation; the georef's anchor is the
    plan centroid of the points.
    """
    p = np.asarray(plan_xy, float).reshape(-1, 2)
    q = np.asarray(lonlat, float).reshape(-1, 2)
    if len(p) != len(q) or len(p) < 2:
        raise ValueError("give at least two control points, each plan x, y and lat, lon")
    if not (np.all(np.isfinite(p)) and np.all(np.isfinite(q))):
        raise ValueError("control points must be finite numbers")
    centre = GeoRef(lat=float(q[:, 1].mean()), lon=float(q[:, 0].mean()), alt=alt)
    en = centre.from_wgs84(np.column_stack([q, np.full(len(q), alt)]))[:, :2]
    pc, ec = p - p.mean(axis=0), en - en.mean(axis=0)
    if np.linalg.norm(pc, axis=1).max() < 1.0:
        raise ValueError("control points must be at least a metre apart on the plan")
    # Rotation angle theta (CCW) taking plan to ENU: maximise sum(e . R p).
    theta = math.atan2(float(np.sum(pc[:, 0] * ec[:, 1] - pc[:, 1] * ec[:, 0])),
                       float(np.sum(pc * ec)))
    bearing = (-math.degrees(theta) + 180.0) % 360.0 - 180.0 + 0.0   # no "-0.0"
    anchor_en = en.mean(axis=0)
    lon0, lat0, _ = centre.to_wgs84(np.array([[*anchor_en, 0.0]]))[0]
    geo = GeoRef(lat=float(lat0), lon=float(lon0), bearing=bearing, alt=alt,
                 anchor=(float(p[:, 0].mean()), float(p[:, 1].mean())))
    back = geo.to_wgs84(p)[:, :2]
    residuals = np.linalg.norm(centre.from_wgs84(back)[:, :2] - en, axis=1)
    dot = float(np.sum(pc * ec))
    cross = float(np.sum(pc[:, 0] * ec[:, 1] - pc[:, 1] * ec[:, 0]))
    scale = math.hypot(dot, cross) / float(np.sum(pc ** 2))
    return ControlFit(geo, residuals, scale)
