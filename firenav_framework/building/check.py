"""Plan checks for ``firenav map check``: concrete problems with their locations.

Errors make a plan unfit for map-aided navigation (a room a particle can leave through a
missing wall, a door a walker cannot pass, a stair to nowhere); warnings are unusual
but legal (a free-standing wall end, overlapping rooms, an entrance away from the
building). Every problem names the floor, a plan point [m] and the feature ids.
"""
from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry import LineString, Point

from .model import Building, Floor
from .wall_merge import overlapping_pairs

__all__ = ["Problem", "check_building", "wall_cover", "open_stretches", "JOIN_TOL", "JAMB_TOL"]

#: Wall ends closer than this [m] to another wall are joined to it.
JOIN_TOL = 0.05
#: A door jamb must be this close [m] to a wall; walls may reach this far into a door gap.
JAMB_TOL = 0.15
#: Shortest stretch [m] of a room outline without wall or door that counts as open.
MIN_OPEN = 0.10
#: Storey heights [m] outside this range are reported (a mezzanine or a sports hall may
#: be real; an export that took a vent or a tall obstacle for the ceiling is not).
MIN_STOREY, MAX_STOREY = 2.0, 6.0
#: Stair steps outside these are reported: risers above MAX_RISER [m], goings [m]
#: outside MIN_GOING..MAX_GOING (a flight drawn over a whole stairwell, or squeezed).
MAX_RISER, MIN_GOING, MAX_GOING = 0.25, 0.20, 0.50


@dataclass(frozen=True)
class Problem:
    """One finding: ``severity`` "error" or "warning", a short ``code``, where and what."""

    severity: str
    code: str
    floor: int | None
    xy: tuple[float, float] | None
    feature: str
    message: str

    def __str__(self) -> str:
        where = [] if self.floor is None else [f"floor {self.floor}"]
        if self.xy is not None:
            where.append(f"({self.xy[0]:.2f}, {self.xy[1]:.2f})")
        head = " ".join(where)
        return f"{self.severity}: {head}{' ' if head else ''}{self.feature}: {self.message} [{self.code}]"


def _xy(p) -> tuple[float, float]:
    return (round(float(p[0]), 3), round(float(p[1]), 3))


def check_building(building: Building) -> list[Problem]:
    """All problems of a plan, floor by floor, errors first within a floor."""
    out: list[Problem] = []
    for floor in building.floors:
        out += _check_polygons(floor)
        out += _check_doors(floor)
        out += _check_wall_ends(floor)
        out += _check_duplicate_walls(floor)
        out += _check_open_rooms(floor)
        out += _check_room_overlap(floor)
    out += _check_storeys(building)
    out += _check_stairs(building)
    out += _check_entrances(building)
    rank = {"error": 0, "warning": 1}
    return sorted(out, key=lambda p: (-1 if p.floor is None else p.floor, rank[p.severity]))


def _drawn_walls(floor: Floor) -> tuple[np.ndarray, np.ndarray]:
    """(segments, their indices in floor.walls) of the drawn walls (obstacle edges excluded)."""
    idx = np.flatnonzero(~floor.wall_is_obstacle)
    return floor.walls[idx], idx


def _check_polygons(floor: Floor) -> list[Problem]:
    out = []
    for kind, items in (("room", floor.rooms), ("obstacle", floor.obstacles)):
        for item in items:
            reason = shapely.is_valid_reason(item.polygon)
            if reason == "Valid Geometry":
                continue
            m = re.search(r"\[(-?[\d.eE+-]+) (-?[\d.eE+-]+)\]", reason)
            xy = _xy((float(m.group(1)), float(m.group(2)))) if m else _xy(item.polygon.exterior.coords[0])
            what = "self-intersecting" if "Self-intersection" in reason else "invalid"
            out.append(Problem("error", f"{kind}_invalid", floor.index, xy, f"{kind} {item.id}",
                               f"{what} polygon ({reason})"))
    return out


def _check_doors(floor: Floor) -> list[Problem]:
    segs, idx = _drawn_walls(floor)
    out = []
    gaps = floor.doors + floor.openings
    if not gaps:
        return out
    tree = shapely.STRtree(shapely.linestrings(segs)) if len(segs) else None
    for g in gaps:
        label = f"{g.kind} {g.id}"
        if tree is None:
            out.append(Problem("error", "door_not_on_wall", floor.index, _xy(g.center), label,
                               "floor has no walls to put the door in"))
            continue
        d = shapely.distance(shapely.points(g.jambs)[:, None], shapely.linestrings(segs)[None, :]).min(axis=1)
        far = np.flatnonzero(d > JAMB_TOL)
        if len(far):
            j = far[0]
            out.append(Problem("error", "door_not_on_wall", floor.index, _xy(g.jambs[j]), label,
                               f"jamb is {d[j]:.2f} m from the nearest wall (a door must sit in a "
                               f"wall gap: both jambs within {JAMB_TOL} m of a wall)"))
            continue
        inner = np.linspace(0, 1, 2)
        along = (g.jambs[1] - g.jambs[0]) / g.width
        shrink = min(JAMB_TOL, g.width / 4)
        middle = LineString(g.jambs[0] + along * (shrink + inner[:, None] * (g.width - 2 * shrink)))
        hit = tree.query(middle, predicate="intersects")
        if len(hit):
            w = int(idx[hit[0]])
            cross = middle.intersection(LineString(floor.walls[w]))
            p = cross.representative_point() if not cross.is_empty else Point(g.center)
            out.append(Problem("error", "door_blocked", floor.index, _xy((p.x, p.y)), label,
                               f"wall {floor.wall_ids[w]} runs through the door gap"))
    return out


def _wall_end_links(floor: Floor) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """End points (2W, 2) of the drawn walls, their wall index, and whether each is joined."""
    segs, idx = _drawn_walls(floor)
    ends = segs.reshape(-1, 2)
    owner = np.repeat(np.arange(len(segs)), 2)
    joined = np.zeros(len(ends), dtype=bool)
    if len(segs) > 1:
        tree = shapely.STRtree(shapely.linestrings(segs))
        e, w = tree.query(shapely.points(ends), predicate="dwithin", distance=JOIN_TOL)
        joined[e[w != owner[e]]] = True
    gaps = floor.doors + floor.openings
    if gaps:
        jambs = np.concatenate([g.jambs for g in gaps])
        d = np.linalg.norm(ends[:, None] - jambs[None], axis=2).min(axis=1)
        joined |= d <= JAMB_TOL
    return ends, idx[owner], joined


def _check_wall_ends(floor: Floor) -> list[Problem]:
    ends, owner, joined = _wall_end_links(floor)
    out = []
    outlines = [r.polygon.boundary for r in floor.rooms]
    for k in np.flatnonzero(~joined):
        p = Point(ends[k])
        wid = floor.wall_ids[owner[k]]
        rooms = [r.id for r, b in zip(floor.rooms, outlines) if b.distance(p) <= JOIN_TOL]
        if rooms or not floor.rooms:
            what = f"leaves room {', '.join(rooms)} open" if rooms else "leaves the floor open"
            out.append(Problem("error", "dangling_wall", floor.index, _xy(ends[k]), f"wall {wid}",
                               f"wall end meets no other wall, door or opening: {what}"))
        else:
            inside = any(r.polygon.contains(p) for r in floor.rooms)
            out.append(Problem("warning", "free_wall_end", floor.index, _xy(ends[k]), f"wall {wid}",
                               "free-standing wall end " + ("inside a room" if inside else
                                                            "outside every room")))
    return out


def _check_duplicate_walls(floor: Floor) -> list[Problem]:
    segs, idx = _drawn_walls(floor)
    out = []
    for o in overlapping_pairs(segs, JOIN_TOL):
        wi, wj = floor.wall_ids[idx[o.i]], floor.wall_ids[idx[o.j]]
        name = f"walls {wi} and {wj}" if wi != wj else f"wall {wi} (two of its segments)"
        out.append(Problem("error", "duplicate_wall", floor.index, _xy(o.mid), name,
                           f"overlap for {o.length:.2f} m (drawn twice)"))
    return out


def wall_cover(walls: np.ndarray, gap_jambs: list[np.ndarray]):
    """What closes a room outline: the walls (W, 2, 2) widened by ``JOIN_TOL`` and the door
    and opening lines (jambs (2, 2)) widened by ``JAMB_TOL``; None if nothing."""
    cover = list(shapely.buffer(shapely.linestrings(walls), JOIN_TOL)) if len(walls) else []
    cover += [LineString(j).buffer(JAMB_TOL) for j in gap_jambs]
    return shapely.union_all(cover) if cover else None


def open_stretches(polygon, cover) -> list[LineString]:
    """Stretches (longer than ``MIN_OPEN``) of a room outline that ``cover`` leaves open."""
    rest = polygon.boundary if cover is None else polygon.boundary.difference(cover)
    if rest.is_empty:
        return []
    return [p for p in shapely.get_parts(shapely.line_merge(rest)) if p.length >= MIN_OPEN]


def _check_open_rooms(floor: Floor) -> list[Problem]:
    if not floor.rooms:
        return []
    segs, _ = _drawn_walls(floor)
    cover = wall_cover(segs, [g.jambs for g in floor.doors + floor.openings])
    out = []
    for room in floor.rooms:
        if not room.polygon.is_valid:
            continue   # reported as invalid already
        for piece in open_stretches(room.polygon, cover):
            mid = piece.interpolate(0.5, normalized=True)
            out.append(Problem("error", "room_open", floor.index, _xy((mid.x, mid.y)),
                               f"room {room.id}",
                               f"outline has no wall, door or opening along {piece.length:.2f} m "
                               f"(not counting {JOIN_TOL} m at each wall end)"))
    return out


def _check_room_overlap(floor: Floor) -> list[Problem]:
    polys = [r.polygon for r in floor.rooms]
    if len(polys) < 2:
        return []
    tree = shapely.STRtree(polys)
    a, b = tree.query(polys, predicate="intersects")
    out = []
    for i, j in zip(a, b):
        if i >= j or not (polys[i].is_valid and polys[j].is_valid):
            continue
        inter = polys[i].intersection(polys[j])
        if inter.area > 0.01:
            c = inter.representative_point()
            out.append(Problem("warning", "rooms_overlap", floor.index, _xy((c.x, c.y)),
                               f"rooms {floor.rooms[i].id} and {floor.rooms[j].id}",
                               f"overlap by {inter.area:.2f} m^2"))
    return out


def _check_stairs(building: Building) -> list[Problem]:
    out = []
    n = len(building.floors)
    for s in building.stairs:
        label = f"stair {s.id}"
        if not 0 <= s.floor_to < n or s.floor_to == s.floor_from:
            out.append(Problem("error", "stair_unconnected", s.floor_from, _xy(s.top), label,
                               f"floor_to {s.floor_to} is not another floor of the building "
                               f"(floors 0..{n - 1}): the stair connects nothing"))
            continue
        for end, fl, name in ((s.bottom, s.floor_from, "bottom"), (s.top, s.floor_to, "top")):
            outline = building.floor(fl).outline
            if outline.distance(Point(end)) > JOIN_TOL:
                out.append(Problem("error", "stair_end_outside", fl, _xy(end), label,
                                   f"{name} end lies outside the building on floor {fl}"))
        steps = f"{s.n_steps} steps of {abs(s.step_height):.3f} m over {s.flight_length:.2f} m"
        if abs(s.step_height) > MAX_RISER or s.going < MIN_GOING:
            out.append(Problem("warning", "stair_steep", s.floor_from, _xy(s.bottom), label,
                               f"{steps} (going {s.going:.2f} m): steeper than a stair "
                               f"(risers up to {MAX_RISER} m, goings from {MIN_GOING} m)"))
        elif s.going > MAX_GOING:
            out.append(Problem("warning", "stair_shallow", s.floor_from, _xy(s.bottom), label,
                               f"{steps} (going {s.going:.2f} m): longer than a stair of "
                               f"this rise (goings up to {MAX_GOING} m); is the walking "
                               "line the flight?"))
    return out


def _check_storeys(building: Building) -> list[Problem]:
    """Storey heights outside MIN_STOREY..MAX_STOREY, and heights that disagree with the
    gap to the next floor level."""
    out = []
    floors = building.floors
    for k, f in enumerate(floors):
        label = f"floor {f.index} ({f.name})" if f.name and f.name != str(f.index) else f"floor {f.index}"
        if k + 1 < len(floors):
            gap = floors[k + 1].z - f.z
            if abs(gap - f.height) > 0.01:
                out.append(Problem("warning", "floor_height_mismatch", f.index, None, label,
                                   f"height {f.height:.2f} m, but floor {k + 1} is {gap:.2f} m "
                                   f"above it (level {f.z:.2f} -> {floors[k + 1].z:.2f} m)"))
            storey, how = gap, f"from level {f.z:.2f} to {floors[k + 1].z:.2f} m"
        else:
            storey, how = f.height, "its height (top floor)"
        if not MIN_STOREY <= storey <= MAX_STOREY:
            out.append(Problem("warning", "storey_height", f.index, None, label,
                               f"storey {storey:.2f} m high ({how}), outside the usual "
                               f"{MIN_STOREY:g}-{MAX_STOREY:g} m: check the floor levels"))
    return out


def _check_entrances(building: Building) -> list[Problem]:
    out = []
    for e in building.entrances:
        d = building.floor(e.floor).outline.distance(Point(e.position))
        if d > 1.0:
            out.append(Problem("warning", "entrance_outside", e.floor, _xy(e.position),
                               f"entrance {e.id}", f"{d:.2f} m away from the building outline"))
    return out
