"""Search patterns extracted from a floor plan (search-pattern paper §IV-C).

Firefighters search a building by following its walls: in a *right-hand* search they
keep the wall on their right (turning right at each entry, left in each corner), a
*left-hand* search is the same walk in the opposite direction (§II, Fig. 1). The
paper turns this into node sequences on a grid:

1. A square grid of nodes at ``spacing`` (1 m in §V-B) is laid over the free space,
   aligned with the building's principal wall direction. Nodes closer than
   ``clearance`` of a wall are dropped; two 4-neighbours are joined by an edge when
   the step between them crosses no wall.
2. The first node is the one closest to the entrance; each next node is the one a
   right-hand search along the grid reaches next, until the walk returns to the
   start (§IV-C). On the grid this is the right-hand rule: from the current node
   and heading, step right if possible, else straight, else left, else back.
3. Inner walls not connected to the outer walls are never touched by that walk;
   "additional node sequences where the first node is chosen among nodes close to
   these inner walls" (§IV-C, grey circles of Fig. 3) are walked around them.
4. The patterns compared with the odometry (§IV-D) are overlapping sub-sequences
   of fixed length ``d`` (20 m), one starting at every node (:meth:`subpatterns`).

Implementation: with the grid embedded in the plane, a right-hand walk traces one
*face* of the grid graph (the region on its right). Every directed edge belongs to
exactly one face, so tracing all of them finds every sequence at once. Faces whose
walk turns left in total (+360 deg) are the outer boundaries of connected parts
of the grid; faces that turn right in total (-360 deg) are unit grid cells or, when
longer than one cell, loops around walls or obstacles standing free inside the
space: the inner-wall sequences. Outer faces of grid parts the entrance's part does
not reach (rooms behind doors the plan treats as walls) are kept as sequences too,
since a firefighter can be there.

The sequences are cyclic (the last node is adjacent to the first, §IV-C) and a node
can occur more than once (a one-node-wide dead end is walked in and out).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np
import shapely

if TYPE_CHECKING:
    from .model import Building, Floor

__all__ = ["NodeSequence", "SearchPatterns", "SubPatterns", "extract_search_patterns",
           "principal_wall_angle"]

#: Grid directions in the grid's own frame: 0 east, 1 north, 2 west, 3 south.
_STEPS = np.array([[1, 0], [0, 1], [-1, 0], [0, -1]])
#: Right-hand rule: try a right turn first, then straight, left, back (turn in quarter turns).
_RIGHT_HAND = (-1, 0, 1, 2)


@dataclass(frozen=True)
class NodeSequence:
    """One cyclic node sequence (the paper's {p_n^(m)}).

    ``nodes`` (N,) indexes :attr:`SearchPatterns.nodes`. ``kind`` is ``"outer"``
    (along the outer walls of a connected part of the floor) or ``"inner"`` (around
    walls standing free inside it); ``hand`` is ``"right"`` or ``"left"``.
    ``matched`` says whether the pattern comparison uses it: a left-hand sequence is
    its right-hand twin walked backwards, which the comparison already covers by
    testing both ends of every pattern (§IV-D, the two columns of E_m).
    """

    name: str
    floor: int
    nodes: np.ndarray
    kind: str
    hand: str
    matched: bool = True

    def __len__(self) -> int:
        return len(self.nodes)


@dataclass(frozen=True)
class SubPatterns:
    """Overlapping fixed-length sub-patterns of the matched sequences, as arrays (§IV-D).

    K patterns of L = dN + 1 nodes each: ``points`` (K, L, 2) [m]; ``sequence`` (K,)
    index into :attr:`SearchPatterns.sequences`; ``start`` (K,) the start index eta
    in that sequence; ``first_node``/``last_node`` (K,) node indices of p_eta and
    p_{eta+dN}; ``first_heading`` (K,) = Hea_m(eta, 1) = atan2(-dp_eta), the walking
    direction of a left-hand search arriving at p_eta; ``last_heading`` (K,) =
    Hea_m(eta, 2) = atan2(dp_{eta+dN}), that of a right-hand search at p_{eta+dN}
    (Algorithm 1, step 14; dp_n = p_{n+1} - p_n); ``floor`` (K,).
    """

    points: np.ndarray
    sequence: np.ndarray
    start: np.ndarray
    first_node: np.ndarray
    last_node: np.ndarray
    first_heading: np.ndarray
    last_heading: np.ndarray
    floor: np.ndarray
    length_m: float

    def __len__(self) -> int:
        return len(self.points)


@dataclass
class SearchPatterns:
    """The node grid and the node sequences of one or more floors.

    ``nodes`` (n, 2) [m] building frame, ``node_floor`` (n,), ``edges`` (E, 2) node
    index pairs, ``sequences`` the named :class:`NodeSequence` list. ``spacing`` [m]
    and ``angle`` [rad] (direction of the grid's x axis, i.e. of the building's
    principal walls) per floor in ``spacing``/``angle``.
    """

    nodes: np.ndarray
    node_floor: np.ndarray
    edges: np.ndarray
    sequences: list[NodeSequence]
    spacing: dict[int, float]
    angle: dict[int, float]
    notes: list[str] = field(default_factory=list)

    def sequence(self, name: str, floor: int | None = None) -> NodeSequence:
        """The sequence called ``name`` (on ``floor`` when given)."""
        for s in self.sequences:
            if s.name == name and (floor is None or s.floor == floor):
                return s
        known = ", ".join(s.name for s in self.sequences)
        raise KeyError(f"no search pattern sequence {name!r}; known: {known}")

    def positions(self, seq: NodeSequence) -> np.ndarray:
        """(N, 2) node positions of a sequence [m]."""
        return self.nodes[seq.nodes]

    def subpatterns(self, length_m: float = 20.0, step_m: float | None = None,
                    floors: Sequence[int] | None = None) -> SubPatterns:
        """Every sub-pattern of about ``length_m`` [m] (§IV-D), starting every ``step_m``.

        dN is chosen so that the pattern's length dN * spacing is as close as possible
        to ``length_m``; ``step_m`` defaults to the grid spacing (a pattern starts at
        every node, as in Algorithm 1). Sequences wrap around (p_N is adjacent to p_1).
        """
        if length_m <= 0:
            raise ValueError(f"pattern length must be > 0 m, got {length_m}")
        pts, seq_i, start, first, last, h1, h2, fl = [], [], [], [], [], [], [], []
        for m, seq in enumerate(self.sequences):
            if not seq.matched or (floors is not None and seq.floor not in floors):
                continue
            s = self.spacing[seq.floor]
            dn = max(1, int(round(length_m / s)))
            every = 1 if step_m is None else max(1, int(round(step_m / s)))
            n = len(seq.nodes)
            eta = np.arange(0, n, every)
            idx = seq.nodes[(eta[:, None] + np.arange(dn + 2)[None, :]) % n]
            p = self.nodes[idx]                               # (k, dn + 2, 2)
            d_first = p[:, 1] - p[:, 0]
            d_last = p[:, dn + 1] - p[:, dn]
            pts.append(p[:, :dn + 1])
            seq_i.append(np.full(len(eta), m))
            start.append(eta)
            first.append(idx[:, 0])
            last.append(idx[:, dn])
            h1.append(_heading(-d_first))
            h2.append(_heading(d_last))
            fl.append(np.full(len(eta), seq.floor))
        if not pts:
            raise ValueError("no node sequence to build patterns from (empty floor plan?)")
        lengths = {p.shape[1] for p in pts}
        if len(lengths) > 1:
            raise ValueError("floors with different grid spacings give patterns of different "
                             "node counts; extract them separately")
        return SubPatterns(points=np.concatenate(pts), sequence=np.concatenate(seq_i),
                           start=np.concatenate(start), first_node=np.concatenate(first),
                           last_node=np.concatenate(last), first_heading=np.concatenate(h1),
                           last_heading=np.concatenate(h2), floor=np.concatenate(fl),
                           length_m=float(length_m))

    def draw(self, ax: Any, floor: int = 0, *, grid: bool = True) -> None:
        """Draw one floor's grid (grey) and the right-hand / inner sequences on matplotlib
        axes, with an arrow at each sequence's start (used by ``firenav map show --patterns``)."""
        on = self.node_floor == floor
        if grid and on.any():
            from matplotlib.collections import LineCollection
            e = self.edges[on[self.edges[:, 0]]]
            ax.add_collection(LineCollection(self.nodes[e], colors="0.8", linewidths=0.4, zorder=6))
            ax.scatter(*self.nodes[on].T, s=3, color="0.55", zorder=6)
        colours = {"outer": "#ff7f0e", "inner": "#8c564b"}
        for seq in self.sequences:
            if seq.floor != floor or seq.hand != "right":
                continue
            ring = np.vstack([self.positions(seq), self.positions(seq)[:1]])
            ax.plot(ring[:, 0], ring[:, 1], "-o", color=colours[seq.kind], ms=2.5, lw=0.8,
                    alpha=0.85, zorder=7, label=f"{seq.name} ({len(seq)} nodes)")
            ax.annotate("", xy=ring[1], xytext=ring[0], zorder=8,
                        arrowprops={"arrowstyle": "-|>", "color": colours[seq.kind], "lw": 1.2})


# --------------------------------------------------------------------------- extraction

def _heading(v: np.ndarray) -> np.ndarray:
    """Direction of vectors (n, 2) [rad] in (-pi, pi] (atan2 gives -pi for (-1, -0.0))."""
    h = np.arctan2(v[:, 1], v[:, 0])
    return np.where(h <= -math.pi, math.pi, h)


def principal_wall_angle(walls: np.ndarray) -> float:
    """Principal wall direction [rad] in [-pi/4, pi/4): length-weighted mean of 4*theta / 4."""
    d = walls[:, 1] - walls[:, 0]
    length = np.hypot(d[:, 0], d[:, 1])
    if not len(d) or length.sum() == 0:
        return 0.0
    theta = np.arctan2(d[:, 1], d[:, 0])
    a = math.atan2(float(length @ np.sin(4 * theta)), float(length @ np.cos(4 * theta))) / 4
    a = round(a, 12)  # a plan drawn along x/y gives exactly 0, not round-off
    return a if a < math.pi / 4 else a - math.pi / 2


@dataclass
class _Grid:
    """Nodes of one floor's grid in grid coordinates (i, j) and their 4-neighbours."""

    ij: np.ndarray          # (n, 2) int
    xy: np.ndarray          # (n, 2) building frame [m]
    nbr: np.ndarray         # (n, 4) neighbour node index per direction, -1 if none
    clearance: np.ndarray   # (n,) distance to the nearest wall [m]

    def score(self, spacing: float) -> tuple[int, float]:
        """Nodes in the largest connected part, then how centred nodes sit between walls."""
        centred = float(np.minimum(self.clearance, spacing / 2).mean()) if len(self.ij) else 0.0
        return _largest_part(self.nbr), round(centred, 9)


def _rot(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s], [s, c]])


def _build_grid(floor: "Floor", spacing: float, angle: float, origin: np.ndarray,
                clearance: float) -> _Grid:
    """Grid nodes inside ``floor``'s free space, at least ``clearance`` from any wall."""
    space = floor.free_space
    to_grid = _rot(-angle)
    x0, y0, x1, y1 = space.bounds
    corners = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]]) @ to_grid.T
    lo = np.floor((corners.min(0) - origin) / spacing).astype(int) - 1
    hi = np.ceil((corners.max(0) - origin) / spacing).astype(int) + 1
    ii, jj = np.meshgrid(np.arange(lo[0], hi[0] + 1), np.arange(lo[1], hi[1] + 1), indexing="ij")
    ij = np.column_stack([ii.ravel(), jj.ravel()])
    xy = (origin + ij * spacing) @ to_grid          # back to the building frame (R(angle))
    keep = shapely.contains_xy(space, xy[:, 0], xy[:, 1])
    ij, xy = ij[keep], xy[keep]
    dist = floor.nearest_wall(xy)[0] if len(floor.walls) else np.full(len(xy), np.inf)
    keep = dist >= clearance
    ij, xy, dist = ij[keep], xy[keep], dist[keep]
    n = len(ij)
    nbr = np.full((n, 4), -1, dtype=np.int64)
    if n:
        key = {(int(i), int(j)): k for k, (i, j) in enumerate(ij)}
        for d in (0, 1):  # east and north links; west/south are their reverses
            step = _STEPS[d]
            a = np.arange(n)
            b = np.array([key.get((int(i + step[0]), int(j + step[1])), -1) for i, j in ij])
            a, b = a[b >= 0], b[b >= 0]
            if len(a):
                ok = ~floor.crosses_wall(xy[a], xy[b]) if len(floor.walls) else np.ones(len(a), bool)
                mid = (xy[a] + xy[b]) / 2
                ok &= shapely.contains_xy(space, mid[:, 0], mid[:, 1])
                a, b = a[ok], b[ok]
                nbr[a, d] = b
                nbr[b, d + 2] = a
    return _Grid(ij=ij, xy=xy, nbr=nbr, clearance=dist)


def _parts(nbr: np.ndarray) -> np.ndarray:
    """Connected-part label of every node."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    n = len(nbr)
    a, d = np.nonzero(nbr >= 0)
    graph = coo_matrix((np.ones(len(a)), (a, nbr[a, d])), shape=(n, n))
    return connected_components(graph, directed=False)[1]


def _largest_part(nbr: np.ndarray) -> int:
    return int(np.bincount(_parts(nbr)).max()) if len(nbr) else 0


def _next_dart(nbr: np.ndarray, node: int, heading: int) -> tuple[int, int] | None:
    """From ``node`` arrived with ``heading``, the next (node, heading) by the right-hand rule."""
    for turn in _RIGHT_HAND:
        d = (heading + turn) % 4
        if nbr[node, d] >= 0:
            return node, d
    return None


def _trace(nbr: np.ndarray, node: int, d: int) -> tuple[list[tuple[int, int]], int]:
    """Right-hand walk from dart (node, d) until it repeats: its darts and total turning.

    Turning is counted in quarter turns (left +1, right -1, back +2).
    """
    darts, turning = [], 0
    start = (node, d)
    cur = start
    while True:
        darts.append(cur)
        nxt = _next_dart(nbr, int(nbr[cur[0], cur[1]]), cur[1])
        assert nxt is not None  # the edge back always exists
        turn = (nxt[1] - cur[1]) % 4
        turning += {0: 0, 1: 1, 2: 2, 3: -1}[turn]
        cur = nxt
        if cur == start:
            return darts, turning


def _grid_heading(angle: float, grid_angle: float) -> int:
    return int(round((angle - grid_angle) / (math.pi / 2))) % 4


def _start_points(building: "Building | None", floor: "Floor",
                  entrance: Any) -> list[tuple[np.ndarray, float | None]]:
    """Where walks on this floor begin: entrances, else arrivals from stairs."""
    if entrance is not None:
        if hasattr(entrance, "position"):
            return [(np.asarray(entrance.position, float)[:2], getattr(entrance, "heading", None))]
        e = np.asarray(entrance, dtype=float).ravel()
        if e.size not in (2, 3):
            raise ValueError("entrance must be an Entrance, (x, y) or (x, y, heading)")
        return [(e[:2], float(e[2]) if e.size == 3 else None)]
    out: list[tuple[np.ndarray, float | None]] = []
    if building is not None:
        out += [(np.asarray(e.position, float), e.heading) for e in building.entrances
                if e.floor == floor.index]
        for f in building.floors:
            for s in f.stairs:
                if s.floor_to == floor.index:
                    out.append((np.asarray(s.top, float), math.atan2(*s.top_direction[::-1])))
                elif s.floor_from == floor.index:
                    out.append((np.asarray(s.bottom, float), math.atan2(*(-s.direction)[::-1])))
    return out


def _floor_sequences(grid: _Grid, floor: int, grid_angle: float,
                     starts: list[tuple[np.ndarray, float | None]]) -> tuple[list[NodeSequence], list[str]]:
    nbr = grid.nbr
    n = len(nbr)
    notes: list[str] = []
    face_of: dict[tuple[int, int], int] = {}
    faces: list[tuple[list[int], int]] = []
    for node in range(n):
        for d in range(4):
            if nbr[node, d] >= 0 and (node, d) not in face_of:
                darts, turning = _trace(nbr, node, d)
                for dart in darts:
                    face_of[dart] = len(faces)
                faces.append((darts, turning))
    parts = _parts(nbr) if n else np.zeros(0, int)
    seqs: list[NodeSequence] = []
    used: set[int] = set()

    def rotate_to(darts: list[tuple[int, int]], first: tuple[int, int]) -> np.ndarray:
        k = darts.index(first)
        return np.array([dd[0] for dd in darts[k:] + darts[:k]], dtype=np.int64)

    # 1. right- and left-hand walks from each entrance (or stair arrival)
    for k, (pos, heading) in enumerate(starts):
        linked = np.flatnonzero((nbr >= 0).any(axis=1))
        if not len(linked):
            break
        node = int(linked[np.argmin(np.hypot(*(grid.xy[linked] - pos).T))])
        # arriving from outside: heading into the building, else away from the nearest wall side
        if heading is None:
            heading = math.atan2(*(grid.xy[node] - pos)[::-1]) if np.any(grid.xy[node] != pos) else 0.0
        h = _grid_heading(heading, grid_angle)
        first = _next_dart(nbr, node, h)
        face = face_of[first]
        if faces[face][1] != 4:  # not along the outer walls: start on the part's outer face
            outer = [f for f, (darts, turning) in enumerate(faces)
                     if turning == 4 and parts[darts[0][0]] == parts[node]]
            face = outer[0]
            darts = faces[face][0]
            first = min((dd for dd in darts), key=lambda dd: np.hypot(*(grid.xy[dd[0]] - pos)))
        if face in used:
            continue
        used.add(face)
        suffix = "" if k == 0 else f"_{k + 1}"
        right = rotate_to(faces[face][0], first)
        seqs.append(NodeSequence(f"right_hand{suffix}", floor, right, "outer", "right"))
        # the left-hand search from the same start follows the same walls the other way
        left = np.concatenate([right[:1], right[:0:-1]])
        seqs.append(NodeSequence(f"left_hand{suffix}", floor, left, "outer", "left", matched=False))
    ref = starts[0][0] if starts else (grid.xy[0] if n else np.zeros(2))

    def nearest_dart(darts: list[tuple[int, int]]) -> tuple[int, int]:
        return min(darts, key=lambda dd: (float(np.hypot(*(grid.xy[dd[0]] - ref))), dd))

    # 2. outer walks of parts no start reaches, 3. loops around free-standing walls
    n_part = n_inner = 0
    for f, (darts, turning) in enumerate(faces):
        if f in used:
            continue
        if turning == 4:
            n_part += 1
            seqs.append(NodeSequence(f"part_{n_part}", floor, rotate_to(darts, nearest_dart(darts)),
                                     "outer", "right"))
        elif turning == -4 and len(darts) > 4:
            n_inner += 1
            seqs.append(NodeSequence(f"inner_{n_inner}", floor, rotate_to(darts, nearest_dart(darts)),
                                     "inner", "right"))
        elif turning not in (4, -4):
            notes.append(f"floor {floor}: a grid face turns {turning * 90} deg in total; skipped")
    isolated = int(np.sum(~(nbr >= 0).any(axis=1)))
    if isolated:
        notes.append(f"floor {floor}: {isolated} grid node(s) without neighbours (no sequence)")
    if not starts:
        notes.append(f"floor {floor}: no entrance or stair; walks start at the first grid node")
    return seqs, notes


def extract_search_patterns(building_or_floor: "Building | Floor", entrance: Any = None,
                            spacing: float = 1.0, *, clearance: float | None = None,
                            angle: float | None = None, origin: Sequence[float] | None = None
                            ) -> SearchPatterns:
    """Extract the search-pattern grid and node sequences of a building or one floor.

    ``entrance``: where the right-hand walk starts — an :class:`Entrance`, ``(x, y)``
    or ``(x, y, heading)`` [m, rad]; by default the building's entrances (and, on
    floors without one, the stair ends). ``spacing`` [m] is the grid spacing (1 m in
    §V-B); ``clearance`` [m] the least distance of a node from a wall (default a
    quarter of the spacing); ``angle`` [rad] the grid's x direction (default: the
    principal wall direction). ``origin`` (2,) [m] places a node in the grid frame;
    by default the offset (in quarter spacings) that connects the most nodes is used,
    so narrow doors are not missed by an unlucky alignment.
    """
    if spacing <= 0:
        raise ValueError(f"grid spacing must be > 0 m, got {spacing}")
    clearance = spacing / 10 if clearance is None else clearance
    if hasattr(building_or_floor, "floors"):
        building, floors = building_or_floor, list(building_or_floor.floors)
    else:
        building, floors = None, [building_or_floor]
    if entrance is not None and len(floors) > 1:
        raise ValueError("an explicit entrance needs a single floor: pass building.floors[i]")
    all_xy, all_floor, all_edges, seqs, notes = [], [], [], [], []
    spacings: dict[int, float] = {}
    angles: dict[int, float] = {}
    base = 0
    for fl in floors:
        a = principal_wall_angle(fl.walls) if angle is None else float(angle)
        if origin is not None:
            grid = _build_grid(fl, spacing, a, np.asarray(origin, float), clearance)
        else:
            offsets = [np.array([i, j]) * spacing / 8 for i in range(8) for j in range(8)]
            grids = [_build_grid(fl, spacing, a, o, clearance) for o in offsets]
            grid = max(grids, key=lambda g: g.score(spacing))
        fseqs, fnotes = _floor_sequences(grid, fl.index, a, _start_points(building, fl, entrance))
        seqs += [NodeSequence(s.name, s.floor, s.nodes + base, s.kind, s.hand, s.matched)
                 for s in fseqs]
        notes += fnotes
        a_idx, d_idx = np.nonzero(grid.nbr[:, :2] >= 0)
        all_edges.append(np.column_stack([a_idx, grid.nbr[a_idx, d_idx]]) + base)
        all_xy.append(grid.xy)
        all_floor.append(np.full(len(grid.xy), fl.index))
        spacings[fl.index] = spacing
        angles[fl.index] = a
        base += len(grid.xy)
    return SearchPatterns(nodes=np.concatenate(all_xy), node_floor=np.concatenate(all_floor),
                          edges=np.concatenate(all_edges).astype(np.int64), sequences=seqs,
                          spacing=spacings, angle=angles, notes=notes)
