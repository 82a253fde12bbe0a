"""The building as it really is, from the plan the fire service has.

A scenario's ``building`` is the plan handed to the pipeline; its ``world`` block says how
the real building differs from it (docs/scenarios.md, "True world and given plan"):

* ``furniture``: beds, desks, cupboards and sofas against the walls of every room and
  clutter along corridors, drawn per seed; the plan shows none of it, the walkers go
  round it (their searches follow its outline, the router avoids it);
* ``obstacles``: furniture placed by hand (boxes ``[x0, y0, x1, y1]``);
* ``changes``: the ways real plans are wrong: ``remove_wall`` (the plan draws a wall that
  is not there, e.g. a door drawn as a wall: the world has an opening there),
  ``add_wall`` (a partition the plan does not show), ``brick_up`` (a door walled up
  since), ``move_door`` (the door is elsewhere on its wall), ``split_room`` (a room
  divided by a partition with a door).

:func:`build_world` applies them to the plan and returns the true building; the
simulator walks it and computes every truth from it, while the ``simulator`` source
gives the pipeline the plan (:mod:`~firenav_framework.sources.simulator`).
"""
from __future__ import annotations

import dataclasses
import numpy as np
import shapely
from shapely.geometry import LineString, Point, Polygon, box
from shapely.ops import split

from ..building import Building, Door, Obstacle, Room
from ..building.geojson_format import make_floor

__all__ = ["WorldError", "build_world", "FURNITURE", "CLUTTER"]

#: Furniture against a room's walls: (name, length along the wall, depth) [m].
FURNITURE = (("bed", 2.0, 0.9), ("desk", 1.4, 0.7), ("cupboard", 1.0, 0.6),
             ("sofa", 2.0, 0.9), ("shelves", 1.2, 0.35), ("cabinet", 0.8, 0.45),
             ("table", 1.6, 0.8))
#: Clutter along a corridor wall (boxes, a trolley, a hose reel).
CLUTTER = (("boxes", 0.8, 0.5), ("trolley", 1.0, 0.55), ("reel", 0.6, 0.4))
#: Body clearance for the check that furniture never cuts a floor in two [m].
PASSAGE_CLEARANCE = 0.4


class WorldError(ValueError):
    """A world change that cannot be applied; ``where`` is its path in the scenario."""

    def __init__(self, where: tuple, message: str):
        super().__init__(message)
        self.where = where


@dataclasses.dataclass
class _FloorEdit:
    """One floor while it is being changed: drawn walls and features, copied."""

    walls: list[np.ndarray]
    wall_ids: list[str]
    doors: list[Door]
    openings: list[Door]
    rooms: list[Room]
    obstacles: list[Obstacle]

    @classmethod
    def of(cls, floor) -> "_FloorEdit":
        drawn = ~floor.wall_is_obstacle
        return cls(walls=[w.copy() for w in floor.walls[drawn]],
                   wall_ids=[i for i, d in zip(floor.wall_ids, drawn) if d],
                   doors=[dataclasses.replace(d, wall=None) for d in floor.doors],
                   openings=[dataclasses.replace(d, wall=None) for d in floor.openings],
                   rooms=list(floor.rooms), obstacles=list(floor.obstacles))

    def cut(self, a: np.ndarray, b: np.ndarray, width: float) -> int:
        """Remove the wall between points ``a`` and ``b`` (a gap in line with them,
        ``width`` [m] wide across); returns how many wall pieces were cut."""
        cutter = LineString([a, b]).buffer(width / 2, cap_style="flat")
        walls, ids, hit = [], [], 0
        for seg, wid in zip(self.walls, self.wall_ids):
            line = LineString(seg)
            if not line.intersects(cutter):
                walls.append(seg)
                ids.append(wid)
                continue
            hit += 1
            rest = line.difference(cutter)
            for part in shapely.get_parts(rest):
                if part.length > 1e-3:
                    walls.append(np.asarray(part.coords)[[0, -1]])
                    ids.append(wid)
        self.walls, self.wall_ids = walls, ids
        return hit

    def floor(self, old):
        return make_floor(old.index, old.z, old.height, old.name, self.walls, self.wall_ids,
                          doors=self.doors, openings=self.openings, rooms=self.rooms,
                          stairs=old.stairs, obstacles=self.obstacles,
                          drawn_outline=old.drawn_outline)


def _nearest_wall(edit: _FloorEdit, p: np.ndarray, where: tuple) -> tuple[int, np.ndarray]:
    """Index of the drawn wall nearest to ``p`` (within 0.5 m) and its unit direction."""
    if not edit.walls:
        raise WorldError(where, "the floor has no walls")
    d = [LineString(w).distance(Point(p)) for w in edit.walls]
    i = int(np.argmin(d))
    if d[i] > 0.5:
        raise WorldError(where, f"no wall within 0.5 m of ({p[0]:.2f}, {p[1]:.2f})")
    w = edit.walls[i]
    return i, (w[1] - w[0]) / np.linalg.norm(w[1] - w[0])


def _gap(edit: _FloorEdit, door_id: str, where: tuple) -> tuple[list[Door], Door]:
    for group in (edit.doors, edit.openings):
        for d in group:
            if d.id == door_id:
                return group, d
    known = ", ".join(d.id for d in edit.doors + edit.openings)
    raise WorldError(where, f"no door or opening {door_id!r} on this floor; here: {known}")


def _change(edit: _FloorEdit, kind: str, spec, floor_index: int, where: tuple) -> None:
    if kind == "remove_wall":
        # the gap is an opening of the world (a door the plan draws as a wall, a wall
        # taken out): people walk through it like through a doorway
        p = np.asarray(spec.at, float)
        i, u = _nearest_wall(edit, p, where + ("at",))
        w = edit.walls[i]
        p = w[0] + np.clip((p - w[0]) @ u, 0.0, np.linalg.norm(w[1] - w[0])) * u
        a, b = p - u * spec.length_m / 2, p + u * spec.length_m / 2
        edit.cut(a, b, 0.1)
        edit.openings.append(Door.from_jambs(f"world_opening{len(edit.openings) + 1}",
                                             floor_index, a, b, kind="opening"))
    elif kind == "add_wall":
        a, b = np.asarray(spec.start, float), np.asarray(spec.end, float)
        edit.walls.append(np.array([a, b]))
        edit.wall_ids.append(f"world_wall{len(edit.walls)}")
    elif kind == "brick_up":
        group, d = _gap(edit, spec, where)
        group.remove(d)
        edit.walls.append(d.jambs.copy())
        edit.wall_ids.append(f"{d.id}_bricked")
    elif kind == "move_door":
        group, d = _gap(edit, spec.door, where + ("door",))
        along = np.array([d.axis[1], -d.axis[0]])
        centre = d.center + spec.by_m * along
        group.remove(d)
        edit.walls.append(d.jambs.copy())
        edit.wall_ids.append(f"{d.id}_old_place")
        if not edit.cut(centre - along * d.width / 2, centre + along * d.width / 2, 0.1):
            raise WorldError(where + ("by_m",), f"no wall {spec.by_m:+.2f} m along from door "
                             f"{d.id!r} to move it to")
        group.append(dataclasses.replace(d, center=centre))
    elif kind == "split_room":
        room = next((r for r in edit.rooms if r.id == spec.room), None)
        if room is None:
            raise WorldError(where + ("room",), f"no room {spec.room!r} on floor {floor_index}")
        x0, y0, x1, y1 = room.polygon.bounds
        f = spec.at
        if spec.across == "x":       # the partition runs along y, at x = x0 + f (x1 - x0)
            c = x0 + f * (x1 - x0)
            line = np.array([[c, y0 - 0.01], [c, y1 + 0.01]])
        else:
            c = y0 + f * (y1 - y0)
            line = np.array([[x0 - 0.01, c], [x1 + 0.01, c]])
        parts = [g for g in shapely.get_parts(split(room.polygon, LineString(line)))
                 if g.area > 0.5]
        if len(parts) != 2:
            raise WorldError(where, f"a partition at {spec.across} fraction {f} does not split "
                             f"room {spec.room!r} in two")
        wall = LineString(line).intersection(room.polygon)
        seg = np.asarray(wall.coords)[[0, -1]]
        blocked = [d.id for d in edit.doors + edit.openings
                   if LineString(seg).distance(Point(*d.center)) < d.width / 2 + 0.3]
        if blocked:
            raise WorldError(where + ("at",), f"the partition would run through "
                             f"{', '.join(blocked)}; move it ('at')")
        edit.walls.append(seg)
        edit.wall_ids.append(f"{room.id}_partition")
        u = (seg[1] - seg[0]) / np.linalg.norm(seg[1] - seg[0])
        centre = seg[0] + spec.door_at * (seg[1] - seg[0])
        a, b = centre - u * spec.door_width / 2, centre + u * spec.door_width / 2
        edit.cut(a, b, 0.1)
        edit.doors.append(Door.from_jambs(f"{room.id}_partition_door", floor_index, a, b))
        edit.rooms.remove(room)
        parts.sort(key=lambda g: (g.centroid.x, g.centroid.y))
        edit.rooms += [dataclasses.replace(room, polygon=parts[0]),
                       dataclasses.replace(room, id=f"{room.id}_b", polygon=parts[1],
                                           name=f"{room.name} (partitioned off)")]
    else:  # pragma: no cover - validated in scenario.py
        raise ValueError(kind)


def _pieces_along(room: Polygon, catalogue, count: int, keep_out, rng: np.random.Generator,
                  prefix: str, floor: int) -> list[Obstacle]:
    """Up to ``count`` pieces from ``catalogue`` against the walls of ``room``."""
    edges = []
    for boundary in [room.exterior, *room.interiors]:     # a ring corridor has both
        ring = np.asarray(boundary.coords)
        edges += [(ring[i], ring[i + 1]) for i in range(len(ring) - 1)
                  if np.linalg.norm(ring[i + 1] - ring[i]) > 1.2]
    placed: list[Obstacle] = []
    if not edges:
        return placed
    inner = room.buffer(-0.01)
    for k in range(count):
        for _ in range(12):                       # a few tries per piece
            name, length, depth = catalogue[int(rng.integers(len(catalogue)))]
            a, b = edges[int(rng.integers(len(edges)))]
            e = np.linalg.norm(b - a)
            if e < length + 0.2:
                continue
            u = (b - a) / e
            n = np.array([-u[1], u[0]])
            if not room.contains(Point(*(0.5 * (a + b) + 0.3 * n))):
                n = -n                           # point into the room
            s0 = rng.uniform(0.05, e - length - 0.05)
            p0 = a + u * s0 + n * 0.02
            poly = Polygon([p0, p0 + u * length, p0 + u * length + n * depth, p0 + n * depth])
            if not inner.contains(poly) or poly.intersects(keep_out):
                continue
            if any(poly.distance(o.polygon) < 0.9 for o in placed):
                continue
            placed.append(Obstacle(f"{prefix}_{name}{k + 1}", floor, poly))
            break
    return placed


def _passages(edit: _FloorEdit, old, room: str) -> int:
    """Separate walkable parts of one room at body clearance (its doors open)."""
    from .geometry import walkable_region
    region = walkable_region(edit.floor(old), PASSAGE_CLEARANCE, rooms=[room])
    return len(shapely.get_parts(region))


def _furnish(edit: _FloorEdit, old, spec, rng: np.random.Generator) -> None:
    """Furniture along room walls and clutter along corridors; a room whose furniture
    would cut its walkable area in two loses pieces (the last placed first)."""
    gaps = edit.doors + edit.openings
    keep_out = shapely.union_all(
        [Point(*d.center).buffer(spec.keep_clear_m) for d in gaps]
        + [st.polygon.buffer(spec.keep_clear_m) for st in old.stairs]
        + [o.polygon.buffer(0.6) for o in edit.obstacles] + [Polygon()])
    for room in list(edit.rooms):
        if room.use == "stairwell":
            continue
        corridor = room.use in ("corridor", "hall")
        lo, hi = spec.corridor if corridor else spec.per_room
        count = int(rng.integers(lo, hi + 1))
        short = min(np.ptp(np.asarray(room.polygon.exterior.coords), axis=0))
        if count == 0 or short < (2.0 if corridor else 2.4):
            continue
        pieces = _pieces_along(room.polygon, CLUTTER if corridor else FURNITURE, count,
                               keep_out, rng, f"world_{room.id}", old.index)
        if not pieces:
            continue
        before = _passages(edit, old, room.id)
        edit.obstacles.extend(pieces)
        while pieces and _passages(edit, old, room.id) > before:
            edit.obstacles.remove(pieces.pop())


def build_world(plan: Building, spec, rng: np.random.Generator,
                base: Building | None = None) -> Building:
    """The true building: ``base`` (default ``plan``) with ``spec``'s changes, obstacles
    and furniture (drawn with ``rng``). Raises :class:`WorldError` with the change's path
    in the scenario (``("world", "changes", i, ...)``) when one cannot be applied."""
    b = base if base is not None else plan
    if spec is None:
        return b
    edits = {f.index: _FloorEdit.of(f) for f in b.floors}
    for i, ch in enumerate(spec.changes):
        kind, value = ch.kind()
        fl = ch.floor
        if fl not in edits:
            raise WorldError(("world", "changes", i), f"the building has floors "
                             f"0..{len(b.floors) - 1}")
        _change(edits[fl], kind, value, fl, ("world", "changes", i, kind))
    for k, ob in enumerate(spec.obstacles):
        if ob.floor not in edits:
            raise WorldError(("world", "obstacles", k), f"the building has floors "
                             f"0..{len(b.floors) - 1}")
        edits[ob.floor].obstacles.append(Obstacle(f"world_obstacle{k + 1}", ob.floor,
                                                  box(*ob.box)))
    if spec.furniture is not None:
        for f in b.floors:
            _furnish(edits[f.index], f, spec.furniture, rng)
    floors = [edits[f.index].floor(f) for f in b.floors]
    return dataclasses.replace(b, floors=floors, name=f"{b.name} (as it really is)",
                               notes=[*b.notes, "the simulated world, not the plan"])


def describe(world: Building, plan: Building) -> dict[str, object]:
    """What differs between the world and the plan (for the truth file)."""
    out: dict[str, object] = {}
    for fw, fp in zip(world.floors, plan.floors):
        ids_w = {d.id for d in fw.doors + fw.openings}
        ids_p = {d.id for d in fp.doors + fp.openings}
        out[f"floor{fw.index}"] = {
            "furniture": [o.id for o in fw.obstacles if o.id not in {p.id for p in fp.obstacles}],
            "doors_not_in_plan": sorted(ids_w - ids_p),
            "doors_not_in_world": sorted(ids_p - ids_w),
            "walls": int(len(fw.walls) - int(fw.wall_is_obstacle.sum())),
            "plan_walls": int(len(fp.walls) - int(fp.wall_is_obstacle.sum()))}
    return out

