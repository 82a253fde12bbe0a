"""The building model shared by every map-aided method.

Frame and units: one local level frame per building, metres, x/y horizontal and z up,
origin at the building origin and common to all floors (ENU when the georef bearing is
0, see :mod:`.georef`). Headings are radians counter-clockwise from +x.

Walls are zero-thickness segments; doors and openings are *gaps* in the walls, described
by their own features (centre, width, the axis through them). A floor's geometry is held
as arrays (walls ``(W, 2, 2)``) with a uniform-grid index built once on first use, so the
particle filter's inner loop (:meth:`Floor.crosses_wall`) is one compiled pass.
"""
from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import NamedTuple

import numpy as np
import shapely
from shapely.geometry import LineString, MultiPolygon, Polygon
from shapely.geometry.base import BaseGeometry

from .georef import GeoRef
from .index import SegmentIndex, _as_points

__all__ = ["BuildingError", "Door", "Room", "Stair", "Obstacle", "Anchor", "Entrance",
           "Floor", "Building", "DoorCrossing", "NOMINAL_STEP_HEIGHT"]

#: Nominal step height [m] used when a stair does not say how many steps it has:
#: the RFID/MEMS paper (rfid-mems-ekf, "MEMS Navigation Module") counts 20 cm per stair.
NOMINAL_STEP_HEIGHT = 0.20


class BuildingError(ValueError):
    """An invalid building plan (the message names the file, the feature and the problem)."""


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


@dataclass(eq=False)
class Door:
    """A door (or an opening without a door) in a wall.

    ``center`` (2,) [m]; ``width`` [m] jamb to jamb; ``axis`` (2,) unit vector through the
    door, i.e. the crossing direction (a heading known up to 180 degrees). ``wall`` is the
    index of a wall segment the door sits in line with (one of its jamb walls), or None.
    ``kind`` is ``"door"`` or ``"opening"`` (a doorless gap; no tag is put on it).
    """

    id: str
    floor: int
    center: np.ndarray
    width: float
    axis: np.ndarray
    wall: int | None = None
    kind: str = "door"

    @property
    def jambs(self) -> np.ndarray:
        """(2, 2) jamb points; walking along ``axis``, the first jamb is on the left."""
        along = np.array([self.axis[1], -self.axis[0]]) * (self.width / 2)
        return np.array([self.center - along, self.center + along])

    @property
    def heading(self) -> float:
        """Crossing heading [rad] along ``axis`` (the other crossing is this + pi)."""
        return math.atan2(self.axis[1], self.axis[0])

    @classmethod
    def from_jambs(cls, id: str, floor: int, a: np.ndarray, b: np.ndarray, **kw) -> "Door":
        """Door whose jambs are ``a`` and ``b``; ``axis`` is the left normal of a -> b."""
        a, b = np.asarray(a, float), np.asarray(b, float)
        d = b - a
        width = float(np.hypot(*d))
        return cls(id=id, floor=floor, center=(a + b) / 2, width=width,
                   axis=np.array([-d[1], d[0]]) / width, **kw)


@dataclass(eq=False)
class Room:
    """A room, corridor, hall or stairwell: a polygon on one floor. ``use`` says which."""

    id: str
    floor: int
    polygon: Polygon
    name: str = ""
    use: str = "room"


@dataclass(eq=False)
class Obstacle:
    """A fixed obstacle (furniture, shaft, pillar): not walkable; its edges block like walls."""

    id: str
    floor: int
    polygon: Polygon


@dataclass(eq=False)
class Stair:
    """A flight (or a run of flights with landings) from one floor level to another.

    ``path`` (K, 2) [m] is the walking line from the ``bottom`` (on ``floor_from``) to the
    ``top`` (on ``floor_to``); a U-shaped stair has its turn in the path. ``z_from`` and
    ``z_to`` are the floor levels [m]. ``polygon`` is the stair's footprint (by default
    the path widened to ``width``; a stair laid out in a stairwell covers its flights and
    half landing). Height grows linearly with distance along the path.
    """

    id: str
    floor_from: int
    floor_to: int
    path: np.ndarray
    width: float
    z_from: float
    z_to: float
    n_steps: int = 0
    polygon: Polygon | None = None

    def __post_init__(self) -> None:
        if not self.n_steps:
            self.n_steps = max(1, round(abs(self.rise) / NOMINAL_STEP_HEIGHT))
        if self.polygon is None:
            self.polygon = self.default_polygon()

    def default_polygon(self) -> Polygon:
        """The footprint when none is given: the walking line widened to ``width``."""
        return LineString(self.path).buffer(self.width / 2, cap_style="flat", join_style="mitre")

    @property
    def bottom(self) -> np.ndarray:
        return self.path[0]

    @property
    def top(self) -> np.ndarray:
        return self.path[-1]

    @property
    def rise(self) -> float:
        """Height gained from bottom to top [m]."""
        return self.z_to - self.z_from

    @property
    def step_height(self) -> float:
        return self.rise / self.n_steps

    @property
    def length(self) -> float:
        """Horizontal length of the walking line [m]."""
        return float(np.sum(np.linalg.norm(np.diff(self.path, axis=0), axis=1)))

    @property
    def flight_length(self) -> float:
        """Horizontal length of the flights [m]: with three or more path segments the first
        and last are flights and those between landings; otherwise the whole line."""
        seg = np.linalg.norm(np.diff(self.path, axis=0), axis=1)
        return float(seg[0] + seg[-1]) if len(seg) >= 3 else float(seg.sum())

    @property
    def going(self) -> float:
        """Mean tread depth [m] (flight length over the number of steps)."""
        return self.flight_length / self.n_steps

    @property
    def direction(self) -> np.ndarray:
        """Unit vector of the climb at the bottom (the rise direction of the first flight)."""
        return _unit(self.path[1] - self.path[0])

    @property
    def top_direction(self) -> np.ndarray:
        """Unit vector of the climb where it arrives at the top."""
        return _unit(self.path[-1] - self.path[-2])

    def flights(self) -> list[Stair]:
        """The stair's flights, lowest first, each a :class:`Stair` of its own that climbs
        (``z_from`` < ``z_to``, walking line from its lower end) with its share of the steps.

        A walking line of three or more segments is flight - landing(s) - flight: the steps
        are on the first and the last segment, split in proportion to their lengths (at
        least one each), the two flights meeting the landing level; the segments between
        are flat landings, on no flight (a U-shaped stair). A line of one or two segments,
        or a stair of one step, is one flight (an L-shaped stair turns on winders).
        """
        path = np.asarray(self.path, float)
        lo, hi = min(self.z_from, self.z_to), max(self.z_from, self.z_to)
        floor_lo, floor_hi = sorted((self.floor_from, self.floor_to))
        if self.z_to < self.z_from:          # walking line given from the upper end
            path = path[::-1]
        seg = np.linalg.norm(np.diff(path, axis=0), axis=1)
        n = int(self.n_steps)

        def flight(line: np.ndarray, z0: float, z1: float, steps: int) -> Stair:
            return Stair(self.id, floor_lo, floor_hi, line, self.width, z0, z1, steps)

        if len(seg) < 3 or n < 2:
            return [flight(path, lo, hi, max(n, 1))]
        first = int(np.floor(n * seg[0] / (seg[0] + seg[-1])))
        first = min(max(first, 1), n - 1)
        z_landing = lo + (hi - lo) * first / n
        return [flight(path[:2], lo, z_landing, first),
                flight(path[-2:], z_landing, hi, n - first)]

    def position_at(self, frac: np.ndarray | float) -> np.ndarray:
        """ENU points (..., 3) [m] at fractions of the walking line (0 bottom, 1 top)."""
        f = np.clip(np.asarray(frac, dtype=float), 0.0, 1.0)
        seg = np.linalg.norm(np.diff(self.path, axis=0), axis=1)
        s = np.concatenate([[0.0], np.cumsum(seg)])
        target = f * s[-1]
        x = np.interp(target, s, self.path[:, 0])
        y = np.interp(target, s, self.path[:, 1])
        return np.stack([x, y, self.z_from + f * self.rise], axis=-1)


@dataclass(eq=False)
class Anchor:
    """A fixed radio node: ``kind`` "base_station", "uwb", ...; ``position`` (3,) ENU [m]."""

    id: str
    kind: str
    position: np.ndarray
    floor: int


@dataclass(eq=False)
class Entrance:
    """Where firefighters come in: ``position`` (2,) [m], ``heading`` into the building [rad]."""

    id: str
    floor: int
    position: np.ndarray
    heading: float
    door: str | None = None


class DoorCrossing(NamedTuple):
    """A path crossed a door between samples ``index`` and ``index + 1``.

    ``direction`` is +1 when the crossing went along the door's axis, -1 against it.
    """

    index: int
    door: str
    direction: int


@dataclass(eq=False)
class Floor:
    """One storey: level ``z`` [m], floor-to-floor ``height`` [m] and its geometry.

    ``walls`` (W, 2, 2) [m] holds every blocking segment: the drawn walls first, then the
    edges of obstacles (``wall_is_obstacle`` tells which); ``wall_ids`` names the feature
    each segment came from. ``stairs`` are the stairs that start on this floor.
    """

    index: int
    z: float
    height: float
    walls: np.ndarray
    name: str = ""
    wall_ids: list[str] = field(default_factory=list)
    wall_is_obstacle: np.ndarray | None = None
    doors: list[Door] = field(default_factory=list)
    openings: list[Door] = field(default_factory=list)
    rooms: list[Room] = field(default_factory=list)
    stairs: list[Stair] = field(default_factory=list)
    obstacles: list[Obstacle] = field(default_factory=list)
    drawn_outline: BaseGeometry | None = None

    def __post_init__(self) -> None:
        self.walls = np.ascontiguousarray(np.asarray(self.walls, dtype=np.float64).reshape(-1, 2, 2))
        if not self.wall_ids:
            self.wall_ids = [f"wall{i}" for i in range(len(self.walls))]
        if self.wall_is_obstacle is None:
            self.wall_is_obstacle = np.zeros(len(self.walls), dtype=bool)
        if len(self.wall_ids) != len(self.walls) or len(self.wall_is_obstacle) != len(self.walls):
            raise BuildingError(f"floor {self.index}: wall_ids/wall_is_obstacle do not match "
                                f"the {len(self.walls)} wall segments")

    # ------------------------------------------------------------------ derived geometry

    @cached_property
    def wall_index(self) -> SegmentIndex:
        """The uniform grid over ``walls`` (built on first use, then reused)."""
        return SegmentIndex(self.walls)

    @cached_property
    def _door_index(self) -> SegmentIndex:
        return SegmentIndex(np.array([d.jambs for d in self.doors + self.openings]).reshape(-1, 2, 2))

    @cached_property
    def outline(self) -> BaseGeometry:
        """Footprint of the building on this floor (Polygon or MultiPolygon).

        The drawn ``floor`` outline when the plan has one; otherwise the faces closed by
        the walls with their door and opening gaps bridged, merged with the rooms and
        stairs; the convex hull of the walls as a last resort.
        """
        if self.drawn_outline is not None:
            return self.drawn_outline
        lines = [LineString(s) for s in self.walls] + [LineString(d.jambs)
                                                        for d in self.doors + self.openings]
        parts: list[BaseGeometry] = []
        if lines:
            parts.extend(shapely.get_parts(shapely.polygonize(
                shapely.get_parts(shapely.union_all(lines)))))
        parts += [shapely.make_valid(r.polygon) for r in self.rooms]
        parts += [s.polygon for s in self.stairs]
        shape = shapely.union_all(parts) if parts else Polygon()
        if shape.is_empty and len(self.walls):
            shape = shapely.convex_hull(shapely.multipoints(self.walls.reshape(-1, 2)))
        # Close slivers between rooms drawn a hair apart.
        shape = shape.buffer(1e-6, join_style="mitre").buffer(-1e-6, join_style="mitre")
        return _polygonal(shape)

    @cached_property
    def free_space(self) -> BaseGeometry:
        """Walkable area: the outline minus obstacles (walls have no area)."""
        space = self.outline
        if self.obstacles:
            space = space.difference(shapely.union_all([o.polygon for o in self.obstacles]))
        space = _polygonal(space)
        shapely.prepare(space)
        return space

    @cached_property
    def _rooms_tree(self) -> shapely.STRtree:
        return shapely.STRtree([r.polygon for r in self.rooms])

    # ------------------------------------------------------------------ queries

    def crosses_wall(self, p0: np.ndarray, p1: np.ndarray) -> np.ndarray:
        """bool (N,): does the move p0[i] -> p1[i] (N, 2) [m] touch a wall?

        Touching counts (a move ending exactly on a wall crosses it); a move through a
        door gap does not, since doors are gaps between wall segments.
        """
        return self.wall_index.crosses(p0, p1)

    def first_wall_hit(self, p0: np.ndarray, p1: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(hit (N,), fraction of the move in [0, 1] at the first wall contact (NaN if none),
        wall index (N,), -1 if none)."""
        return self.wall_index.first_hit(p0, p1)

    def nearest_wall(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(distance (N,) [m], closest wall point (N, 2), wall index (N,))."""
        return self.wall_index.nearest(points)

    def walls_near(self, point: np.ndarray, radius: float) -> np.ndarray:
        """Indices of the walls within ``radius`` [m] of ``point`` (2,)."""
        return self.wall_index.near(point, radius)

    def room_of(self, points: np.ndarray) -> np.ndarray:
        """int (N,): index into ``rooms`` of the room holding each point, -1 if none.

        A point on a wall shared by two rooms goes to the lower room index.
        """
        pts = _as_points(points, "points")
        out = np.full(len(pts), -1, dtype=np.int64)
        if not self.rooms or not len(pts):
            return out
        src, room = self._rooms_tree.query(shapely.points(pts), predicate="intersects")
        big = np.iinfo(np.int64).max
        best = np.full(len(pts), big, dtype=np.int64)
        np.minimum.at(best, src, room)
        out[best != big] = best[best != big]
        return out

    def inside(self, points: np.ndarray) -> np.ndarray:
        """bool (N,): is each point inside the building outline (boundary included)?"""
        pts = _as_points(points, "points")
        outline = self.outline
        shapely.prepare(outline)
        return shapely.intersects_xy(outline, pts[:, 0], pts[:, 1])

    def door_crossings(self, path: np.ndarray, include_openings: bool = False) -> list[DoorCrossing]:
        """Doors crossed by a path (M, 2) [m], in path order.

        A crossing is a change of side of the door line (a point exactly on the line
        counts as the +axis side) between two consecutive samples, within the door's
        width. With ``include_openings`` doorless openings are reported too.
        """
        pts = _as_points(path, "path")
        gaps = self.doors + self.openings
        if len(pts) < 2 or not gaps:
            return []
        seg, k = self._door_index.all_hits(pts[:-1], pts[1:])
        if not include_openings:
            keep = k < len(self.doors)
            seg, k = seg[keep], k[keep]
        centers = np.array([g.center for g in gaps])[k]
        axes = np.array([g.axis for g in gaps])[k]
        sa = np.einsum("ij,ij->i", pts[seg] - centers, axes)
        sb = np.einsum("ij,ij->i", pts[seg + 1] - centers, axes)
        crossed = (sa >= 0) != (sb >= 0)
        seg, k, sa, sb = seg[crossed], k[crossed], sa[crossed], sb[crossed]
        frac = sa / (sa - sb)
        order = np.lexsort((frac, seg))
        return [DoorCrossing(int(seg[i]), gaps[k[i]].id, 1 if sb[i] >= 0 else -1) for i in order]

    def sample_free(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """(n, 2) points drawn uniformly over the free space [m] (rejection sampling)."""
        space = self.free_space
        if space.is_empty or space.area <= 0:
            raise BuildingError(f"floor {self.index}: no free space to sample from "
                                "(no outline, rooms or closed walls)")
        x0, y0, x1, y1 = space.bounds
        fill = space.area / ((x1 - x0) * (y1 - y0))
        out = np.empty((0, 2))
        while len(out) < n:
            m = int((n - len(out)) / fill * 1.2) + 16
            cand = np.column_stack([rng.uniform(x0, x1, m), rng.uniform(y0, y1, m)])
            out = np.vstack([out, cand[shapely.contains_xy(space, cand[:, 0], cand[:, 1])]])
        return out[:n]


def _polygonal(shape: BaseGeometry) -> BaseGeometry:
    """Keep only the areal parts of a geometry (Polygon or MultiPolygon)."""
    if isinstance(shape, (Polygon, MultiPolygon)):
        return shape
    polys = [g for g in shapely.get_parts(shape) if isinstance(g, (Polygon, MultiPolygon))]
    return shapely.union_all(polys) if polys else Polygon()


@dataclass(eq=False)
class Building:
    """A whole building: floors (index 0 is the lowest), fixed anchors, entrances, georef."""

    name: str
    floors: list[Floor]
    anchors: list[Anchor] = field(default_factory=list)
    entrances: list[Entrance] = field(default_factory=list)
    georef: GeoRef | None = None
    source: Path | None = None
    #: What an importer assumed or changed (units, merged features), for the user to read.
    notes: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        if not self.floors:
            raise BuildingError(f"building {self.name!r} has no floors")
        for i, f in enumerate(self.floors):
            if f.index != i:
                raise BuildingError(f"floor list out of order: position {i} holds floor {f.index}")
            if i and not f.z > self.floors[i - 1].z:
                raise BuildingError(f"floor {i} level z={f.z} m is not above floor {i - 1} "
                                    f"(z={self.floors[i - 1].z} m)")
        seen: dict[str, str] = {}
        for kind, fid in self._feature_ids():
            if fid in seen:
                raise BuildingError(f"duplicate id {fid!r} ({seen[fid]} and {kind}): "
                                    "ids must be unique in a building")
            seen[fid] = kind
        n = len(self.floors)
        for item in [*self.anchors, *self.entrances]:
            if not 0 <= item.floor < n:
                raise BuildingError(f"{type(item).__name__.lower()} {item.id!r} is on floor "
                                    f"{item.floor}, but the building has floors 0..{n - 1}")

    def _feature_ids(self):
        for f in self.floors:
            for d in f.doors + f.openings:
                yield d.kind, d.id
            for r in f.rooms:
                yield "room", r.id
            for s in f.stairs:
                yield "stair", s.id
            for o in f.obstacles:
                yield "obstacle", o.id
        for a in self.anchors:
            yield "anchor", a.id
        for e in self.entrances:
            yield "entrance", e.id

    def floor(self, i: int) -> Floor:
        if not 0 <= i < len(self.floors):
            raise IndexError(f"building {self.name!r} has floors 0..{len(self.floors) - 1}, "
                             f"not {i}")
        return self.floors[i]

    @cached_property
    def _level_mids(self) -> list[float]:
        """Heights [m] half way between consecutive floor levels (floors are fixed once
        the building is built)."""
        levels = [f.z for f in self.floors]
        return [(a + b) / 2 for a, b in zip(levels, levels[1:])]

    def floor_of_z(self, z: np.ndarray | float) -> np.ndarray | int:
        """Floor index nearest to height ``z`` [m] (switches half way between levels).

        Vectorised: an array in gives an int array out; a scalar gives an int (without
        building arrays: estimators ask once per step).
        """
        if np.ndim(z) == 0:
            return bisect.bisect_right(self._level_mids, float(z))
        out = np.searchsorted(np.asarray(self._level_mids, float),
                              np.asarray(z, dtype=float), side="right")
        return out.astype(np.int64)

    @property
    def doors(self) -> list[Door]:
        """All doors of all floors (openings excluded)."""
        return [d for f in self.floors for d in f.doors]

    @property
    def stairs(self) -> list[Stair]:
        return [s for f in self.floors for s in f.stairs]

    def door(self, door_id: str) -> Door:
        for f in self.floors:
            for d in f.doors + f.openings:
                if d.id == door_id:
                    return d
        raise KeyError(f"building {self.name!r} has no door or opening {door_id!r}")
