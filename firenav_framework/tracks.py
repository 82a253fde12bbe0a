"""Tracks: pose estimates and ground truth gathered per stream and agent, and their files.

CSV columns (one row per pose, ENU metres, radians, seconds)::

    t,agent,x,y,z,heading,var_x,cov_xy,var_y,var_z,var_heading,floor,trusted,protection_radius

``floor`` is empty when unknown; ``protection_radius`` [m] is the horizontal error bound at
99 % containment (``inf``: none promised). GeoJSON holds one LineString per track; its
positions are RFC 7946 WGS84 longitude, latitude and ellipsoidal height when the
building has a geographic reference, otherwise plan metres, and the collection's
``coordinate_frame`` member says which.
"""
from __future__ import annotations

import io
import json
import math
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Iterable

import numpy as np

from .messages import GroundTruth, Message, PoseEstimate

if TYPE_CHECKING:
    from .building.georef import GeoRef

CSV_HEADER = ("t,agent,x,y,z,heading,var_x,cov_xy,var_y,var_z,var_heading,floor,trusted,"
              "protection_radius")


def _num(v: float) -> str:
    """Shortest round-trip text of a float, so output is exact and byte-stable."""
    if not math.isfinite(v):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf")
    return repr(float(v))


def pose_csv_row(msg: PoseEstimate) -> str:
    p, c = msg.position, msg.cov
    floor = "" if msg.floor is None else str(int(msg.floor))
    return ",".join([_num(msg.t), msg.agent, _num(p[0]), _num(p[1]), _num(p[2]),
                     _num(msg.heading), _num(c[0, 0]), _num(c[0, 1]), _num(c[1, 1]),
                     _num(c[2, 2]), _num(c[3, 3]), floor, "1" if msg.trusted else "0",
                     _num(msg.protection_radius)])


@dataclass
class Track:
    """One agent's track as arrays: ``t`` (N,), ``position`` (N, 3), ``heading`` (N,),
    ``cov`` (N, 4, 4), ``floor`` (N,) with -1 for unknown, ``trusted`` (N,) bool,
    ``protection_radius`` (N,) [m] (``inf`` where none was promised, and for truth)."""

    agent: str
    t: np.ndarray
    position: np.ndarray
    heading: np.ndarray
    cov: np.ndarray
    floor: np.ndarray
    trusted: np.ndarray
    protection_radius: np.ndarray
    #: Frame of the positions: "building" for estimates; truth may name another frame.
    frame: str = "building"

    def __len__(self) -> int:
        return len(self.t)

    @property
    def length_m(self) -> float:
        """Horizontal path length [m]."""
        if len(self.t) < 2:
            return 0.0
        return float(np.sum(np.hypot(*np.diff(self.position[:, :2], axis=0).T)))


class _Builder:
    def __init__(self) -> None:
        self.rows: list[tuple] = []
        self.frame = "building"

    def add(self, msg: Message) -> None:
        self.frame = msg.frame
        if isinstance(msg, PoseEstimate):
            self.rows.append((msg.t, msg.position, msg.heading, msg.cov,
                              -1 if msg.floor is None else msg.floor, msg.trusted,
                              msg.protection_radius))
        else:
            assert isinstance(msg, GroundTruth)
            self.rows.append((msg.t, msg.position, msg.heading, None,
                              -1 if msg.floor is None else msg.floor, True, math.inf))

    def build(self, agent: str) -> Track:
        rows = self.rows
        n = len(rows)
        cov = np.full((n, 4, 4), np.nan)
        for i, r in enumerate(rows):
            if r[3] is not None:
                cov[i] = r[3]
        return Track(agent=agent,
                     t=np.fromiter((r[0] for r in rows), float, n),
                     position=np.array([r[1] for r in rows], float).reshape(n, 3),
                     heading=np.fromiter((r[2] for r in rows), float, n),
                     cov=cov,
                     floor=np.fromiter((r[4] for r in rows), int, n),
                     trusted=np.fromiter((r[5] for r in rows), bool, n),
                     protection_radius=np.fromiter((r[6] for r in rows), float, n),
                     frame=self.frame)


class TrackStore:
    """Collects every PoseEstimate and GroundTruth published during a run (a bus tap)."""

    def __init__(self) -> None:
        self._poses: dict[str, dict[str, _Builder]] = defaultdict(lambda: defaultdict(_Builder))
        self._truth: dict[str, _Builder] = defaultdict(_Builder)

    def __call__(self, stream: str, msg: Message) -> None:
        if isinstance(msg, PoseEstimate):
            self._poses[stream][msg.agent].add(msg)
        elif isinstance(msg, GroundTruth):
            self._truth[msg.agent].add(msg)

    def tracks(self) -> dict[str, dict[str, Track]]:
        """``{stream: {agent: Track}}`` of every pose stream."""
        return {s: {a: b.build(a) for a, b in sorted(agents.items())}
                for s, agents in sorted(self._poses.items())}

    def truth(self) -> dict[str, Track]:
        return {a: b.build(a) for a, b in sorted(self._truth.items())}


def write_csv(path: Path, poses: Iterable[PoseEstimate]) -> None:
    buf = io.StringIO()
    buf.write(CSV_HEADER + "\n")
    for p in poses:
        buf.write(pose_csv_row(p) + "\n")
    path.write_text(buf.getvalue(), encoding="utf-8")


def read_csv(path: Path) -> dict[str, Track]:
    """Read a track CSV written by firenav back into arrays, per agent."""
    import csv
    by_agent: dict[str, _Builder] = defaultdict(_Builder)
    with open(path, newline="", encoding="utf-8") as fh:
        for row in csv.DictReader(fh):
            cov = np.zeros((4, 4))
            cov[0, 0], cov[0, 1], cov[1, 0] = float(row["var_x"]), float(row["cov_xy"]), float(row["cov_xy"])
            cov[1, 1], cov[2, 2], cov[3, 3] = float(row["var_y"]), float(row["var_z"]), float(row["var_heading"])
            by_agent[row["agent"]].add(PoseEstimate(
                t=float(row["t"]), agent=row["agent"],
                position=np.array([float(row["x"]), float(row["y"]), float(row["z"])]),
                heading=float(row["heading"]), cov=cov,
                floor=int(row["floor"]) if row["floor"] else None,
                trusted=row.get("trusted", "1") != "0",
                protection_radius=float(row.get("protection_radius") or "inf")))
    return {a: b.build(a) for a, b in sorted(by_agent.items())}


def geojson(tracks: dict[str, dict[str, Track]], georef: "GeoRef | None" = None) -> dict:
    """A GeoJSON FeatureCollection with one LineString per (stream, agent) track.

    With ``georef`` (the building's), positions are RFC 7946 [longitude, latitude,
    ellipsoidal height] on WGS84; without, plan metres [x, y, z], and the top-level
    ``coordinate_frame`` member says that they are local (not WGS84).
    """
    from .building.georef import coordinate_frame
    features = []
    for stream, agents in tracks.items():
        for agent, tr in agents.items():
            finite = tr.position[np.all(np.isfinite(tr.position), axis=1)]  # GeoJSON has no NaN
            if georef is None:
                pos = [[round(float(x), 4), round(float(y), 4), round(float(z), 4)]
                       for x, y, z in finite]
            else:
                pos = [[round(float(lon), 9), round(float(lat), 9), round(float(h), 3)]
                       for lon, lat, h in georef.to_wgs84(finite)]
            last = tr.cov[-1] if len(tr) else np.full((4, 4), np.nan)
            features.append({
                "type": "Feature",
                "geometry": {"type": "LineString", "coordinates": pos},
                "properties": {
                    "stream": stream, "agent": agent,
                    "t_start": float(tr.t[0]) if len(tr) else None,
                    "t_end": float(tr.t[-1]) if len(tr) else None,
                    "length_m": round(tr.length_m, 3),
                    "last_floor": int(tr.floor[-1]) if len(tr) and tr.floor[-1] >= 0 else None,
                    "last_sigma_xy_m": (round(math.sqrt(max(0.0, (last[0, 0] + last[1, 1]) / 2)), 3)
                                        if np.isfinite(last[0, 0]) else None),
                    "last_protection_radius_m": (round(float(tr.protection_radius[-1]), 3)
                                                 if len(tr) and np.isfinite(tr.protection_radius[-1])
                                                 else None),
                    "trusted_fraction": (round(float(np.mean(tr.trusted)), 4) if len(tr) else None),
                },
            })
    return {"type": "FeatureCollection", "coordinate_frame": coordinate_frame(georef),
            "features": features}


def write_geojson(path: Path, tracks: dict[str, dict[str, Track]],
                  georef: "GeoRef | None" = None) -> None:
    path.write_text(json.dumps(geojson(tracks, georef), indent=1) + "\n", encoding="utf-8")
