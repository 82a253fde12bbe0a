"""From a scenario plan to legs: routes, searches, stairs, pauses, tag stops.

The planner knows the building; the :class:`~.movement.Walker` knows feet. Each plan
step becomes one or more :class:`~.movement.Leg` objects:

* ``walk``/``crawl``: a route from where the agent stands to the target, around walls
  and through door centres (:class:`~.geometry.Router`, body 0.4 m from walls), up or
  down stairs when the target is on another floor; ``via`` points are taken as given
  (and refused if a segment crosses a wall).
* ``search``: the hand-on-wall loop of the floor (or of some rooms), ``offset_m`` from
  the walls, right or left handed (search-pattern paper, Sec. II and Fig. 1).
* ``compartmental_search``: each room searched hand-on-wall, then the rooms behind its
  doors in turn, returning the same way (Sec. II).
* ``stairs``: route to the stair, then the flight(s).
* Tag dispensing (RFID paper, "RFID tags"): an agent whose reader has ``deploy``
  stops ``pause_s`` in every door it is the first to pass and at both ends of every
  stair it takes, and a tag with a random id is attached there (top centre of the
  jamb, ``tag_height_m`` above the floor).

Problems (unknown door, unreachable target, a ``via`` line through a wall) become a
:class:`~firenav_framework.yaml_locations.ConfigError` at the plan step's line in the
scenario file.
"""
from __future__ import annotations

import numpy as np
import shapely
from shapely.geometry import LineString, Point

from .geometry import (RouteError, Router, dedupe, polyline_length, resample, walkable_region,
                       wall_ring)
from .movement import Leg
from .scenario import (AgentSpec, CompartmentalSearch, Scenario, Search, Stairs, Step, Stops,
                       Target, Turn, Walk)

ROUTE_CLEARANCE = 0.4   # body centre to wall when walking to somewhere [m]


class TagBook:
    """Tags stuck so far: feature (door or stair end) -> (tag id, true position (3,))."""

    def __init__(self, rng: np.random.Generator):
        self.rng = rng
        self.tags: dict[str, tuple[str, np.ndarray]] = {}

    def attach(self, feature: str, position: np.ndarray) -> tuple[str, np.ndarray] | None:
        if feature in self.tags:
            return None
        tag_id = "E2" + "".join(f"{x:02X}" for x in self.rng.integers(0, 256, 5))
        self.tags[feature] = (tag_id, np.asarray(position, float))
        return self.tags[feature]


class _State:
    def __init__(self, xy: np.ndarray, floor: int, heading: float):
        self.xy = np.asarray(xy, float)
        self.floor = floor
        self.heading = heading


class Planner:
    """Plans every agent of a scenario in one building (routes are cached per floor)."""

    def __init__(self, building, scenario: Scenario, rng: np.random.Generator):
        self.b = building
        self.sc = scenario
        self.rng = rng
        self.tags = TagBook(rng)
        self._regions: dict[tuple, object] = {}
        self._routers: dict[tuple, Router] = {}

    # -- geometry caches ---------------------------------------------------------
    def _stairs_on(self, floor: int) -> list:
        return [s for s in self.b.stairs if floor in (s.floor_from, s.floor_to)]

    def region(self, floor: int, clearance: float, rooms=None, closed=()) -> object:
        key = (floor, round(clearance, 3), tuple(rooms) if rooms else None, tuple(sorted(closed)))
        if key not in self._regions:
            self._regions[key] = walkable_region(self.b.floor(floor), clearance,
                                                 stairs=self._stairs_on(floor), rooms=rooms,
                                                 closed_doors=set(closed))
        return self._regions[key]

    def router(self, floor: int, clearance: float = ROUTE_CLEARANCE) -> Router:
        key = (floor, clearance)
        if key not in self._routers:
            self._routers[key] = Router(self.region(floor, clearance))
        return self._routers[key]

    # -- start --------------------------------------------------------------------
    def start_state(self, agent: AgentSpec, where: tuple) -> _State:
        st = agent.start
        if st.entrance is not None:
            ent = next((e for e in self.b.entrances if e.id == st.entrance), None)
            if ent is None:
                raise self.sc.problem(where + ("start", "entrance"), f"no entrance "
                                      f"'{st.entrance}'; entrances: "
                                      f"{', '.join(e.id for e in self.b.entrances) or 'none'}")
            h = ent.heading if st.heading_deg is None else np.radians(st.heading_deg)
            xy = np.asarray(ent.position, float) + 0.3 * np.array([np.cos(h), np.sin(h)])
            return _State(xy, ent.floor, h)
        if st.position is None:
            if not self.b.entrances:
                raise self.sc.problem(where + ("start",), "give a start position or entrance "
                                      "(the building has no entrances)")
            ent = self.b.entrances[0]
            h = ent.heading
            return _State(np.asarray(ent.position) + 0.3 * np.array([np.cos(h), np.sin(h)]),
                          ent.floor, h)
        if not 0 <= st.floor < len(self.b.floors):
            raise self.sc.problem(where + ("start", "floor"), f"the building has floors "
                                  f"0..{len(self.b.floors) - 1}")
        xy = np.asarray(st.position, float)
        if not self.b.floor(st.floor).inside(xy[None])[0]:
            raise self.sc.problem(where + ("start", "position"), f"({xy[0]}, {xy[1]}) is "
                                  "outside the building")
        return _State(xy, st.floor, np.radians(st.heading_deg or 0.0))

    # -- plans ----------------------------------------------------------------------
    def plan(self, agent: AgentSpec, steps: tuple[Step, ...], where: tuple,
             rng: np.random.Generator | None = None) -> tuple[_State, list[Leg]]:
        """The agent's start and legs; ``rng`` draws its deviations (searches)."""
        self.agent_rng = rng if rng is not None else self.rng
        state = self.start_state(agent, where)
        start = _State(state.xy.copy(), state.floor, state.heading)
        rfid = agent.sensors.rfid
        deploy = rfid if (rfid is not None and rfid.deploy) else None
        legs: list[Leg] = []
        for step in steps:
            try:
                self._step(step, state, legs, deploy)
            except RouteError as exc:
                raise self.sc.problem(step.where + (step.kind,), str(exc)) from None
        return start, legs

    def _step(self, step: Step, st: _State, legs: list[Leg], deploy) -> None:
        k, spec = step.kind, step.spec
        if k == "wait":
            legs.append(Leg("pause", st.floor, duration=spec, where=step.where))
        elif k == "kneel":
            legs.append(Leg("pause", st.floor, duration=spec, posture="kneel", where=step.where))
        elif k in ("walk", "crawl"):
            self._walk(spec, st, legs, deploy, step.where + (k,))
        elif k == "search":
            self._search(spec, st, legs, deploy, step.where + (k,))
        elif k == "compartmental_search":
            self._compartmental(spec, st, legs, deploy, step.where + (k,))
        elif k == "stairs":
            self._stairs_to(spec, st, legs, deploy, step.where + (k,))
        elif k == "turn":
            self._turn(spec, st, legs, step.where)
        elif k == "checkpoint":
            legs.append(Leg("pause", st.floor, duration=spec.stop_s, checkpoint=spec.name,
                            where=step.where))
        elif k == "repeat":
            for _ in range(spec.times):
                for sub in step.plan:
                    self._step(sub, st, legs, deploy)
        else:  # pragma: no cover - validated in scenario.py
            raise ValueError(k)

    # -- steps --------------------------------------------------------------------
    def _turn(self, spec: Turn, st: _State, legs: list[Leg], where: tuple) -> None:
        target = (np.radians(spec.heading_deg) if spec.heading_deg is not None
                  else st.heading + np.radians(spec.by_deg))
        legs.append(Leg("turn", st.floor, heading=float(target), where=where))
        st.heading = float(target)

    def _target(self, spec: Walk, st: _State, where: tuple) -> tuple[int, np.ndarray, list]:
        """(floor, xy, extra points after it) of a walk target."""
        to = spec.to
        if not isinstance(to, Target):
            return st.floor, np.asarray(to, float), []
        floor = st.floor if to.floor is None else to.floor
        if to.position is not None:
            return floor, np.asarray(to.position, float), []
        if to.door is not None:
            try:
                d = self.b.door(to.door)
            except KeyError as exc:
                raise self.sc.problem(where + ("to", "door"), exc.args[0]) from None
            c, ax = np.asarray(d.center, float), np.asarray(d.axis, float)
            # Approach from the side the agent is on (same floor), go 0.8 m beyond.
            side = np.sign((st.xy - c) @ ax) if d.floor == st.floor else -1.0
            side = side or -1.0
            return d.floor, c + side * 0.6 * ax, [c - side * 0.8 * ax]
        if to.room is not None:
            for f in self.b.floors:
                for r in f.rooms:
                    if r.id == to.room:
                        c = r.polygon.centroid
                        p = c if r.polygon.contains(c) else r.polygon.representative_point()
                        return f.index, np.array(p.coords[0]), []
            raise self.sc.problem(where + ("to", "room"), f"no room '{to.room}' in the building")
        if to.entrance is not None:
            ent = next((e for e in self.b.entrances if e.id == to.entrance), None)
            if ent is None:
                raise self.sc.problem(where + ("to", "entrance"), f"no entrance '{to.entrance}'")
            h = np.array([np.cos(ent.heading), np.sin(ent.heading)])
            return ent.floor, np.asarray(ent.position, float) + 0.6 * h, []
        anchors = {a.id: a for a in self.b.anchors}
        anchors.update({a.id: a for a in self.sc.model.anchors})
        a = anchors.get(to.anchor)
        if a is None:
            raise self.sc.problem(where + ("to", "anchor"), f"no anchor '{to.anchor}'; anchors: "
                                  f"{', '.join(sorted(anchors)) or 'none'}")
        return a.floor, np.asarray(a.position, float)[:2], []

    def _walk(self, spec: Walk, st: _State, legs: list[Leg], deploy, where: tuple) -> None:
        if spec.via is not None:
            pts = np.vstack([st.xy, np.asarray(spec.via, float)])
            floor = self.b.floor(st.floor)
            bad = floor.crosses_wall(pts[:-1], pts[1:])
            if bad.any():
                i = int(np.argmax(bad))
                raise self.sc.problem(where + ("via", i), f"the line from ({pts[i][0]:.2f}, "
                                      f"{pts[i][1]:.2f}) to ({pts[i + 1][0]:.2f}, "
                                      f"{pts[i + 1][1]:.2f}) crosses a wall")
            self._move(pts, st, legs, spec.gait, spec.backwards, spec.stops, deploy)
            return
        floor, xy, extra = self._target(spec, st, where)
        if not 0 <= floor < len(self.b.floors):
            raise self.sc.problem(where + ("to",), "the building has floors "
                                  f"0..{len(self.b.floors) - 1}")
        if not self.b.floor(floor).inside(xy[None])[0]:
            raise self.sc.problem(where + ("to",), f"target ({xy[0]:.2f}, {xy[1]:.2f}) is outside "
                                  f"the building on floor {floor}")
        self._change_floor(floor, st, legs, deploy, spec.gait)
        route = self.router(st.floor).route(st.xy, xy)
        if extra:
            route = np.vstack([route, extra])
        self._move(route, st, legs, spec.gait, spec.backwards, spec.stops, deploy)

    def _change_floor(self, floor: int, st: _State, legs: list[Leg], deploy, gait: str,
                      backwards: bool = False) -> None:
        while st.floor != floor:
            up = floor > st.floor
            nxt = st.floor + (1 if up else -1)
            cands = [s for s in self.b.stairs
                     if {s.floor_from, s.floor_to} == {st.floor, nxt}]
            if not cands:
                raise RouteError(f"no stair between floors {st.floor} and {nxt}")
            ends = [(s.bottom if up else s.top) for s in cands]
            stair = cands[int(np.argmin([np.linalg.norm(e - st.xy) for e in ends]))]
            self._take_stair(stair, up, st, legs, deploy, gait, backwards)

    def _take_stair(self, stair, up: bool, st: _State, legs: list[Leg], deploy, gait: str,
                    backwards: bool) -> None:
        path = np.asarray(stair.path, float)
        entry, d = (path[0], path[1] - path[0]) if up else (path[-1], path[-2] - path[-1])
        d = d / np.linalg.norm(d)
        approach = entry - 0.5 * d
        route = self.router(st.floor).route(st.xy, approach)
        self._move(np.vstack([route, entry - 0.3 * d]), st, legs, gait, False, None, deploy)
        here = self.b.floor(st.floor).z + (deploy.tag_height_m if deploy else 0.0)
        if deploy is not None:
            self._deploy_pause(f"{stair.id}/{'bottom' if up else 'top'}",
                               np.array([*entry, here]), st, legs, deploy)
        legs.append(Leg("stairs", st.floor, stair=stair, up=up, backwards=backwards and not up))
        st.floor = stair.floor_to if up else stair.floor_from
        far, d2 = (path[-1], path[-1] - path[-2]) if up else (path[0], path[0] - path[1])
        d2 = d2 / np.linalg.norm(d2)
        st.xy = far + 0.35 * d2
        st.heading = float(np.arctan2(d2[1], d2[0]))
        if deploy is not None:
            z = self.b.floor(st.floor).z + deploy.tag_height_m
            self._deploy_pause(f"{stair.id}/{'top' if up else 'bottom'}",
                               np.array([*far, z]), st, legs, deploy)

    def _stairs_to(self, spec: Stairs, st: _State, legs: list[Leg], deploy, where: tuple) -> None:
        if not 0 <= spec.to_floor < len(self.b.floors):
            raise self.sc.problem(where + ("to_floor",), f"the building has floors "
                                  f"0..{len(self.b.floors) - 1}")
        if spec.to_floor == st.floor:
            raise self.sc.problem(where + ("to_floor",), f"the agent is already on floor "
                                  f"{st.floor} here")
        self._change_floor(spec.to_floor, st, legs, deploy, "walk", spec.backwards)

    def _search(self, spec: Search, st: _State, legs: list[Leg], deploy, where: tuple) -> None:
        dev = spec.deviate
        closed = list(spec.closed_doors)
        if dev is not None and dev.skip_rooms > 0:
            closed += self._skipped_doors(st, dev.skip_rooms)
        region = self.region(st.floor, spec.offset_m, spec.rooms, closed)
        try:
            ring = wall_ring(region, st.xy, spec.hand)
        except RouteError as exc:
            raise self.sc.problem(where, str(exc)) from None
        one = polyline_length(ring)
        total = one * spec.laps if spec.length_m is None else min(spec.length_m, one * spec.laps)
        if dev is not None:
            total *= dev.coverage
        laps = int(np.ceil(total / one))
        loop = np.vstack([ring] + [ring[1:]] * (laps - 1))
        loop = _cut(loop, total)
        if dev is not None:
            loop = _backtracks(_shortcuts(loop, region, dev.leave_wall, self.agent_rng),
                               dev, self.agent_rng)
        approach = self.router(st.floor).route(st.xy, loop[0])
        path = np.vstack([approach, loop[1:]])
        for piece, gait in self._gaits_along(path, st.floor, spec.gait, dev):
            self._move(piece, st, legs, gait, False, spec.stops, deploy,
                       kneel_at_doors=spec.kneel_at_doors_s, deviate=dev)

    def _skipped_doors(self, st: _State, share: float) -> list[str]:
        """Doors of the rooms a search leaves out (each room with probability ``share``;
        never a corridor or the room the search starts in)."""
        floor = self.b.floor(st.floor)
        here = int(floor.room_of(st.xy[None])[0])
        gaps = floor.doors + floor.openings
        out: list[str] = []
        for i, room in enumerate(floor.rooms):
            if i == here or room.use in ("corridor", "hall", "stairwell"):
                continue
            if self.agent_rng.uniform() >= share:
                continue
            for d in gaps:
                sides = floor.room_of(np.array([d.center + 0.6 * d.axis, d.center - 0.6 * d.axis]))
                if i in sides:
                    out.append(d.id)
        return out

    def _gaits_along(self, path: np.ndarray, floor_index: int, gait: str, dev
                     ) -> list[tuple[np.ndarray, str]]:
        """Cut ``path`` where the gait changes: corridor stretches of over 5 m run
        (``run_in_corridors``), random 3-8 m pieces crawled (``crawl_share``)."""
        if dev is None or (not dev.run_in_corridors and dev.crawl_share == 0):
            return [(path, gait)]
        dense, s = resample(path, 0.25)
        label = np.full(len(s), gait, dtype=object)
        if dev.run_in_corridors:
            floor = self.b.floor(floor_index)
            rooms = floor.room_of(dense)
            corridor = np.array([r >= 0 and floor.rooms[r].use == "corridor" for r in rooms])
            for a, b in zip(*_runs(corridor)):
                if s[b - 1] - s[a] > 5.0:
                    label[a:b] = "run"
        crawled, total = 0.0, s[-1] * dev.crawl_share
        for _ in range(50):
            if crawled >= total:
                break
            length = self.agent_rng.uniform(3.0, 8.0)
            a = self.agent_rng.uniform(0.0, max(s[-1] - length, 0.0))
            m = (s >= a) & (s <= a + length) & (label == gait)
            label[m] = "crawl"
            crawled += float(m.sum()) * 0.25
        edges = np.flatnonzero(label[1:] != label[:-1]) + 1
        cut = [float(s[e]) for e in edges]
        pieces = _split(path, cut)
        names = [label[0]] + [label[e] for e in edges]
        return [(p, g) for p, g in zip(pieces, names) if polyline_length(p) > 0.05]

    def _compartmental(self, spec: CompartmentalSearch, st: _State, legs: list[Leg], deploy,
                       where: tuple) -> None:
        floor = self.b.floor(st.floor)
        room_i = int(floor.room_of(st.xy[None])[0])
        if room_i < 0:
            raise self.sc.problem(where, "the agent is not in a room here; walk into one first")
        allowed = set(spec.rooms) if spec.rooms else {r.id for r in floor.rooms}
        done: set[str] = set()
        gaps = floor.doors + floor.openings

        def side_room(door, sign: float) -> str | None:
            p = np.asarray(door.center) + sign * 0.6 * np.asarray(door.axis)
            i = int(floor.room_of(p[None])[0])
            return floor.rooms[i].id if i >= 0 else None

        def search_room(room_id: str, entry_door) -> None:
            done.add(room_id)
            region = self.region(st.floor, spec.offset_m, [room_id])
            ring = wall_ring(region, st.xy, spec.hand)
            self._move(ring, st, legs, spec.gait, False, spec.stops, deploy)
            ring_line = _line(ring)
            todo = []
            for d in gaps:
                if entry_door is not None and d.id == entry_door.id:
                    continue
                sides = {side_room(d, +1.0), side_room(d, -1.0)}
                if room_id not in sides:
                    continue
                other = (sides - {room_id}).pop() if len(sides) == 2 else None
                if other is None or other in done or other not in allowed:
                    continue
                todo.append((ring_line.project(Point(d.center)), d, other))
            for _, d, other in sorted(todo, key=lambda x: x[0]):
                if other in done:
                    continue
                c, ax = np.asarray(d.center, float), np.asarray(d.axis, float)
                s_here = np.sign((st.xy - c) @ ax) or 1.0
                inside_here, beyond = c + s_here * 0.6 * ax, c - s_here * 0.7 * ax
                route = self.router(st.floor).route(st.xy, inside_here)
                self._move(np.vstack([route, c, beyond]), st, legs, spec.gait, False, None, deploy)
                search_room(other, d)
                back = self.router(st.floor).route(st.xy, beyond)
                self._move(np.vstack([back, c, inside_here]), st, legs, spec.gait, False, None,
                           deploy)

        search_room(floor.rooms[room_i].id, None)

    # -- moves -----------------------------------------------------------------------
    def _move(self, path: np.ndarray, st: _State, legs: list[Leg], gait: str, backwards: bool,
              stops: Stops | None, deploy, kneel_at_doors: float = 0.0, deviate=None) -> None:
        path = np.asarray(path, float)
        if np.linalg.norm(path[0] - st.xy) > 1e-6:
            path = np.vstack([st.xy, path])
        if polyline_length(path) < 0.05:
            return
        cuts: list[tuple[float, Leg]] = []
        if kneel_at_doors > 0:
            for c in self.b.floor(st.floor).door_crossings(path):
                s_door = _arc_at_crossing(path, c.index, self.b.door(c.door))
                cuts.append((max(0.0, s_door - 0.5), Leg("pause", st.floor,
                                                         duration=kneel_at_doors,
                                                         posture="kneel")))
        if deploy is not None:
            for c in self.b.floor(st.floor).door_crossings(path):
                door = self.b.door(c.door)
                s_cross = _arc_at_crossing(path, c.index, door)
                z = self.b.floor(st.floor).z + deploy.tag_height_m
                got = self.tags.attach(door.id, np.array([*door.center, z]))
                if got is not None:
                    cuts.append((s_cross, Leg("pause", st.floor, duration=deploy.pause_s,
                                              deploy=[got])))
        if stops is not None:
            total = polyline_length(path)
            s = stops.every_m * self.rng.uniform(0.5, 1.5)
            while s < total - 1.0:
                kneel = stops.kneel_prob > 0 and self.rng.uniform() < stops.kneel_prob
                cuts.append((s, Leg("pause", st.floor, duration=float(
                    self.rng.uniform(*stops.duration_s)), posture="kneel" if kneel else None)))
                s += stops.every_m * self.rng.uniform(0.5, 1.5)
        if deviate is not None and deviate.sweep_every_m is not None:
            total = polyline_length(path)
            s = deviate.sweep_every_m * self.agent_rng.uniform(0.5, 1.5)
            while s < total - 0.5:
                cuts.append((s, Leg("sweep", st.floor,
                                    duration=float(self.agent_rng.uniform(*deviate.sweep_s)))))
                s += deviate.sweep_every_m * self.agent_rng.uniform(0.5, 1.5)
        cuts.sort(key=lambda c: c[0])
        pieces = _split(path, [c[0] for c in cuts])
        for i, piece in enumerate(pieces):
            if polyline_length(piece) > 0.02:
                legs.append(Leg("move", st.floor, path=piece, gait=gait, backwards=backwards))
            if i < len(cuts):
                legs.append(cuts[i][1])
        d = path[-1] - path[-2]
        st.xy = path[-1].copy()
        st.heading = float(np.arctan2(d[1], d[0]) + (np.pi if backwards else 0.0))

    def _deploy_pause(self, feature: str, position: np.ndarray, st: _State, legs: list[Leg],
                      deploy) -> None:
        got = self.tags.attach(feature, position)
        if got is not None:
            legs.append(Leg("pause", st.floor, duration=deploy.pause_s, deploy=[got]))


def _runs(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)


def _shortcuts(loop: np.ndarray, region, chance: float, rng: np.random.Generator
               ) -> np.ndarray:
    """Leave the wall now and then: every 4 m, with ``chance``, replace the next 3-8 m of
    ``loop`` by a straight line inside ``region`` when that is at least 25 % shorter."""
    if chance <= 0:
        return loop
    out = [loop[:1]]
    seg = np.linalg.norm(np.diff(loop, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])

    def at(d: float) -> np.ndarray:
        return np.array([np.interp(d, s, loop[:, 0]), np.interp(d, s, loop[:, 1])])
    d = 0.0
    while d < s[-1]:
        nxt = min(d + 4.0, s[-1])
        if rng.uniform() < chance and d + 3.0 < s[-1]:
            ahead = min(d + rng.uniform(3.0, 8.0), s[-1])
            a, b = at(d), at(ahead)
            if (np.linalg.norm(b - a) < 0.75 * (ahead - d)
                    and shapely.covers(region, LineString([a, b]))):
                out.append(np.array([a, b]))
                d = ahead
                continue
        inner = (s > d) & (s < nxt)
        out.append(np.vstack([at(d)[None], loop[inner], at(nxt)[None]]))
        d = nxt
    return dedupe(np.vstack(out))


def _backtracks(loop: np.ndarray, dev, rng: np.random.Generator) -> np.ndarray:
    """Go back the way one came (``backtrack_m``) and on again, about every
    ``backtrack_every_m`` along ``loop``."""
    if dev.backtrack_every_m is None:
        return loop
    seg = np.linalg.norm(np.diff(loop, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    marks = []
    d = dev.backtrack_every_m * rng.uniform(0.5, 1.5)
    while d < s[-1] - 1.0:
        marks.append((d, min(rng.uniform(*dev.backtrack_m), d)))
        d += dev.backtrack_every_m * rng.uniform(0.5, 1.5)
    if not marks:
        return loop
    pieces = _split(loop, [m[0] for m in marks])
    out = [pieces[0]]
    for (d, back), piece in zip(marks, pieces[1:]):
        done = np.vstack(out)
        ret = _cut(done[::-1], back)             # the last ``back`` metres, walked back
        out += [ret[1:], ret[::-1][1:], piece[1:]]
    return dedupe(np.vstack(out))


def _line(p: np.ndarray):
    from shapely.geometry import LineString
    return LineString(p)


def _cut(path: np.ndarray, length: float) -> np.ndarray:
    """The first ``length`` metres of polyline ``path``."""
    seg = np.linalg.norm(np.diff(path, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    if length >= s[-1]:
        return path
    k = int(np.searchsorted(s, length))
    f = (length - s[k - 1]) / max(seg[k - 1], 1e-12)
    return np.vstack([path[:k], path[k - 1] + f * (path[k] - path[k - 1])])


def _split(path: np.ndarray, at: list[float]) -> list[np.ndarray]:
    """Cut a polyline at arc lengths ``at`` (sorted); the cut points end and start pieces."""
    seg = np.linalg.norm(np.diff(path, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    pieces, last = [], 0.0
    for a in list(at) + [s[-1]]:
        a = float(np.clip(a, last, s[-1]))
        inner = (s > last) & (s < a)
        p0 = np.array([np.interp(last, s, path[:, 0]), np.interp(last, s, path[:, 1])])
        p1 = np.array([np.interp(a, s, path[:, 0]), np.interp(a, s, path[:, 1])])
        pieces.append(np.vstack([p0, path[inner], p1]))
        last = a
    return pieces


def _arc_at_crossing(path: np.ndarray, i: int, door) -> float:
    """Arc length along ``path`` where segment ``i`` crosses the door line."""
    c, ax = np.asarray(door.center, float), np.asarray(door.axis, float)
    sa, sb = (path[i] - c) @ ax, (path[i + 1] - c) @ ax
    f = sa / (sa - sb) if sa != sb else 0.5
    seg = np.linalg.norm(np.diff(path, axis=0), axis=1)
    return float(seg[:i].sum() + f * seg[i])
