"""Where a firefighter can walk on a floor, and routes through it.

* :func:`walkable_region`: the floor's free space shrunk by a body clearance from
  every wall, obstacle and stair, with a narrow passage through each (open) door
  centre. Walking the boundary of this region is a hand-on-wall search: the region's
  exterior ring keeps ``clearance`` from the walls and turns into every room through
  the middle of its door (search-pattern paper, Sec. II).
* :class:`Router`: shortest routes inside a region on a raster (Dijkstra with a mild
  preference for room to spare), straightened by line-of-sight.
* :func:`fillet`: rounds polyline corners into arcs people actually walk.
* :func:`wall_ring`: the hand-on-wall loop from a start point, right- or left-handed.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import shapely
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra
from shapely.geometry import LineString, Point, Polygon
from shapely.geometry.base import BaseGeometry
from shapely.geometry.polygon import orient

__all__ = ["RouteError", "walkable_region", "Router", "fillet", "wall_ring", "polyline_length",
           "resample", "dedupe"]


class RouteError(ValueError):
    """A route or search that cannot be planned (target in a wall, unreachable...)."""


def _polygons(geom: BaseGeometry) -> BaseGeometry:
    parts = [g for g in shapely.get_parts(geom) if isinstance(g, Polygon) and g.area > 1e-6]
    return shapely.union_all(parts) if parts else Polygon()


def walkable_region(floor, clearance: float, *, stairs: list = (),
                    rooms: list[str] | None = None, closed_doors: set[str] = frozenset(),
                    passage: float = 0.2) -> BaseGeometry:
    """Area where a body centre ``clearance`` [m] from every wall can be.

    ``rooms`` limits the area to those rooms (doors between two of them stay open,
    doors leading out are walls); ``closed_doors`` are treated as walls; ``stairs``
    (every stair starting or ending on this floor) are not level floor. Each open
    door gets a ``passage`` [m] wide strip through its centre along its axis.
    """
    space = floor.free_space
    if rooms is not None:
        by_id = {r.id: r for r in floor.rooms}
        missing = [r for r in rooms if r not in by_id]
        if missing:
            raise RouteError(f"floor {floor.index} has no room {', '.join(map(repr, missing))}; "
                             f"rooms: {', '.join(sorted(by_id))}")
        area = shapely.union_all([by_id[r].polygon for r in rooms]).buffer(1e-3)
        space = space.intersection(area)
    blocked = [LineString(w) for w in floor.walls]
    blocked += [LineString(d.jambs) for d in floor.doors + floor.openings if d.id in closed_doors]
    region = space.buffer(-clearance, join_style="mitre")
    if blocked:
        region = region.difference(shapely.union_all(blocked).buffer(clearance, quad_segs=3))
    if stairs:
        region = region.difference(shapely.union_all([s.polygon for s in stairs]).buffer(0.05))
    strips = []
    for d in floor.doors + floor.openings:
        if d.id in closed_doors:
            continue
        half_w = max(0.02, min(passage / 2, d.width / 2 - 0.1))
        half_l = clearance + 0.2
        ax = np.asarray(d.axis, float)
        lat = np.array([-ax[1], ax[0]])
        c = np.asarray(d.center, float)
        corners = [c + ax * half_l + lat * half_w, c - ax * half_l + lat * half_w,
                   c - ax * half_l - lat * half_w, c + ax * half_l - lat * half_w]
        strips.append(Polygon(corners))
    if strips:
        region = region.union(shapely.union_all(strips).intersection(space.buffer(-0.02)))
    region = _polygons(region.buffer(1e-4).buffer(-1e-4))
    shapely.prepare(region)
    return region


def polyline_length(p: np.ndarray) -> float:
    return float(np.sum(np.linalg.norm(np.diff(p, axis=0), axis=1))) if len(p) > 1 else 0.0


def resample(p: np.ndarray, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Points every ``step`` [m] along polyline ``p`` (N, 2) (ends kept); (points, s)."""
    seg = np.linalg.norm(np.diff(p, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    n = max(2, int(np.ceil(s[-1] / step)) + 1)
    si = np.linspace(0.0, s[-1], n)
    return np.column_stack([np.interp(si, s, p[:, 0]), np.interp(si, s, p[:, 1])]), si


def dedupe(p: np.ndarray, tol: float = 1e-6) -> np.ndarray:
    """Polyline ``p`` (N, 2) without consecutive repeated points."""
    keep = np.concatenate([[True], np.linalg.norm(np.diff(p, axis=0), axis=1) > tol])
    return p[keep]


def fillet(p: np.ndarray, radius: float, *, max_turn_deg: float = 120.0, arc_step: float = 0.05
           ) -> tuple[np.ndarray, list[int]]:
    """Round the corners of polyline ``p`` (N, 2) with arcs of up to ``radius`` [m].

    Corners turning more than ``max_turn_deg`` are kept sharp (people turn on the spot
    there); their indices in the returned polyline are listed.
    """
    p = dedupe(np.asarray(p, float))
    if len(p) < 3 or radius <= 0:
        return p, []
    out = [p[0]]
    sharp: list[int] = []
    seg = np.linalg.norm(np.diff(p, axis=0), axis=1)
    for i in range(1, len(p) - 1):
        a, b, c = p[i - 1], p[i], p[i + 1]
        u = (b - a) / seg[i - 1]
        v = (c - b) / seg[i]
        turn = np.arctan2(u[0] * v[1] - u[1] * v[0], u @ v)
        if abs(turn) < 1e-3:
            continue
        if abs(np.degrees(turn)) > max_turn_deg:
            out.append(b)
            sharp.append(len(out) - 1)
            continue
        half = abs(turn) / 2
        # Tangent length limited so neighbouring fillets never overlap.
        tlen = min(radius * np.tan(half), 0.45 * seg[i - 1], 0.45 * seg[i])
        r = tlen / np.tan(half)
        start = b - u * tlen
        left = np.array([-u[1], u[0]]) * np.sign(turn)
        centre = start + left * r
        a0 = np.arctan2(*(start - centre)[::-1])
        n = max(2, int(np.ceil(abs(turn) * r / arc_step)) + 1)
        ang = a0 + np.linspace(0.0, turn, n)
        out.extend(centre + r * np.column_stack([np.cos(ang), np.sin(ang)]))
    out.append(p[-1])
    return dedupe(np.array(out)), sharp


def wall_ring(region: BaseGeometry, start: np.ndarray, hand: str) -> np.ndarray:
    """The closed hand-on-wall loop of the region part holding ``start``.

    Right hand on the wall = the wall on the right = the exterior ring walked
    counter-clockwise; left hand = clockwise. The loop starts and ends at the ring
    point nearest to ``start``.
    """
    part = _part_at(region, start)
    poly = orient(part, sign=1.0 if hand == "right" else -1.0)
    ring = np.asarray(poly.exterior.coords)[:-1]
    line = LineString(np.vstack([ring, ring[:1]]))
    d = line.project(Point(start))
    p0 = np.asarray(line.interpolate(d).coords[0])
    seg = np.linalg.norm(np.diff(np.vstack([ring, ring[:1]]), axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    k = int(np.searchsorted(s, d, side="right"))  # ring vertices after the start point
    k = min(k, len(ring))
    after = np.vstack([ring[k:], ring[:k]])
    return dedupe(np.vstack([p0, after, p0]))


def _part_at(region: BaseGeometry, point: np.ndarray) -> Polygon:
    parts = [g for g in shapely.get_parts(region) if isinstance(g, Polygon)]
    if not parts:
        raise RouteError("the area has no walkable space at this clearance from the walls")
    pt = Point(point)
    dists = [g.distance(pt) for g in parts]
    return parts[int(np.argmin(dists))]


@dataclass
class Router:
    """Shortest routes inside ``region`` on a ``resolution`` [m] raster."""

    region: BaseGeometry
    resolution: float = 0.1
    prefer_room_m: float = 0.3

    @cached_property
    def _grid(self):
        x0, y0, x1, y1 = self.region.bounds
        h = self.resolution
        xs = np.arange(x0 + h / 2, x1, h)
        ys = np.arange(y0 + h / 2, y1, h)
        gx, gy = np.meshgrid(xs, ys)
        inside = shapely.contains_xy(self.region, gx, gy)
        room = ndimage.distance_transform_edt(inside) * h
        idx = -np.ones(inside.shape, np.int64)
        idx[inside] = np.arange(int(inside.sum()))
        rows, cols, w = [], [], []
        ny, nx = inside.shape
        penalty = 1.0 + 2.0 * np.clip((self.prefer_room_m - room) / self.prefer_room_m, 0, 1)
        for dy, dx in ((0, 1), (1, 0), (1, 1), (1, -1)):
            a = inside[max(0, -dy):ny - max(0, dy), max(0, -dx):nx - max(0, dx)]
            sl_b = (slice(max(0, dy), ny - max(0, -dy)), slice(max(0, dx), nx - max(0, -dx)))
            sl_a = (slice(max(0, -dy), ny - max(0, dy)), slice(max(0, -dx), nx - max(0, dx)))
            both = a & inside[sl_b]
            ia, ib = idx[sl_a][both], idx[sl_b][both]
            cost = np.hypot(dx, dy) * h * 0.5 * (penalty[sl_a][both] + penalty[sl_b][both])
            rows += [ia, ib]
            cols += [ib, ia]
            w += [cost, cost]
        n = int(inside.sum())
        graph = coo_matrix((np.concatenate(w), (np.concatenate(rows), np.concatenate(cols))),
                           shape=(n, n)).tocsr()
        pts = np.column_stack([gx[inside], gy[inside]])
        return graph, pts

    def _node(self, p: np.ndarray) -> int:
        graph, pts = self._grid
        if len(pts) == 0:
            raise RouteError("no walkable space")
        return int(np.argmin(np.sum((pts - p) ** 2, axis=1)))

    def snap(self, p: np.ndarray) -> np.ndarray:
        """The nearest point of the region to ``p``."""
        if shapely.contains_xy(self.region, p[0], p[1]):
            return np.asarray(p, float)
        from shapely.ops import nearest_points
        part = _part_at(self.region, p)
        q = nearest_points(part, Point(p))[0]
        # step a hair inside so that later containment tests pass
        c = np.asarray(part.representative_point().coords[0])
        q = np.asarray(q.coords[0])
        return q + (c - q) / max(np.linalg.norm(c - q), 1e-9) * 1e-3

    def route(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Polyline (M, 2) from ``a`` to ``b`` inside the region (ends snapped into it)."""
        a = self.snap(np.asarray(a, float))
        b = self.snap(np.asarray(b, float))
        if shapely.covers(self.region, LineString([a, b])):
            return np.array([a, b])
        graph, pts = self._grid
        ia, ib = self._node(a), self._node(b)
        dist, pred = dijkstra(graph, indices=ia, return_predecessors=True)
        if not np.isfinite(dist[ib]):
            raise RouteError(f"no walkable route from ({a[0]:.2f}, {a[1]:.2f}) to "
                             f"({b[0]:.2f}, {b[1]:.2f}) on this floor")
        chain = [ib]
        while chain[-1] != ia:
            chain.append(pred[chain[-1]])
        path = np.vstack([a, pts[chain[::-1]], b])
        return self._straighten(path)

    def _straighten(self, path: np.ndarray) -> np.ndarray:
        """Greedy line-of-sight shortcutting of a raster path."""
        out = [path[0]]
        i, n = 0, len(path)
        while i < n - 1:
            cand = np.arange(i + 1, n)
            lines = shapely.linestrings(np.stack([np.repeat(path[i][None], len(cand), 0),
                                                  path[cand]], axis=1))
            ok = shapely.covers(self.region, lines)
            j = int(cand[np.nonzero(ok)[0].max()]) if ok.any() else i + 1
            out.append(path[j])
            i = j
        return dedupe(np.array(out))
