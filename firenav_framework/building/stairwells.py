"""Stairs laid out inside a stairwell, from its footprint, its doors and the floor levels.

Exports such as Aamks draw a stairwell only as a box that spans several floors (a STAI
"tower"), not its flights. The stair joining two floors is laid out inside the box:

* The flights run along the box's long axis. Each floor the stairwell serves has a
  **landing** at the end of the box where that floor's stairwell doors are (the doors
  vote by the half of the box they open into); a floor whose doors do not decide
  takes the end of the floor below, else above, so that stacked stairs line up.
* Landings at the same end on both floors give a **U-shaped** stair: a flight up one
  half of the box width, a half landing at the far end, a flight back up the other
  half, arriving on the landing above the start. Landings at opposite ends give a
  **straight** flight across the box. The bottom is on the lower floor (by level), the
  top on the upper one; no stair leaves the top floor the stairwell reaches.
* The run comes from the rise: risers of at most :data:`MAX_RISER`, goings from the
  comfort rule 2R + G = :data:`STEP_RULE` kept within :data:`MIN_GOING`-:data:`MAX_GOING`,
  shortened when the box is too short (``map check`` then warns about the pitch).
* The flights take the box width (half of it each for a U) up to
  :data:`MAX_FLIGHT_WIDTH` per flight, along the long side that leaves every door
  clear, narrower (down to :data:`MIN_FLIGHT_WIDTH`) where a door must stay clear; the
  rest of the box width is a level passage beside them, so doors at both ends of a
  floor (an outside door at one, a corridor at the other, as Aamks stairwells have)
  reach the stair.
* The landing at the door end is :data:`MIN_LANDING` deep, or deeper to take in every
  door of that end that opens onto the long sides; the half landing of a U is as deep
  as a flight is wide (at least :data:`MIN_HALF_LANDING`), and what the box has left
  over deepens the landing at the doors.

The result is a native stair feature (walking line from bottom to top, ``floor_to``,
``width``, ``n_steps`` and its ``footprint``) and a note saying how it was laid out;
a door that opens onto the stair, or cannot reach its end on its floor, is noted too.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import shapely
from shapely.geometry import Polygon

__all__ = ["StairwellSlice", "stairwell_stairs", "MAX_RISER", "STEP_RULE", "MIN_GOING",
           "MAX_GOING", "MIN_LANDING", "MIN_HALF_LANDING", "MAX_FLIGHT_WIDTH",
           "MIN_FLIGHT_WIDTH"]

#: Highest riser [m] a laid-out stair gets.
MAX_RISER = 0.19
#: Comfort rule (Blondel): twice the riser plus the going [m].
STEP_RULE = 0.63
#: Goings [m] a laid-out stair keeps to while the stairwell is long enough.
MIN_GOING, MAX_GOING = 0.22, 0.30
#: Depth [m] of the landing at the door end, and of the half landing of a U-shaped stair.
MIN_LANDING = 1.2
MIN_HALF_LANDING = 1.0
#: Widest and narrowest flight [m] laid out (escape stairs are 1.0-1.5 m wide).
MAX_FLIGHT_WIDTH, MIN_FLIGHT_WIDTH = 1.5, 0.8
#: Clearance [m] kept between a flight and the jamb of a door in the end wall beside it.
DOOR_MARGIN = 0.2
#: A door belongs to a stairwell when its centre is this close [m] to the box outline.
DOOR_TOL = 0.25


@dataclass
class StairwellSlice:
    """The stairwell on one floor: floor index, level ``z`` [m], footprint and the doors
    (id, jambs (2, 2) [m]) in its outline on that floor."""

    floor: int
    z: float
    polygon: Polygon
    doors: list[tuple[str, np.ndarray]] = field(default_factory=list)


@dataclass
class _Box:
    """The stairwell's rectangle: corner, long axis ``u``, short axis ``v``, L >= W [m]."""

    corner: np.ndarray
    u: np.ndarray
    v: np.ndarray
    length: float
    width: float

    @classmethod
    def of(cls, poly: Polygon) -> "_Box":
        rect = np.asarray(shapely.minimum_rotated_rectangle(poly).exterior.coords)[:4]
        e1, e2 = rect[1] - rect[0], rect[3] - rect[0]
        l1, l2 = float(np.hypot(*e1)), float(np.hypot(*e2))
        if l1 < l2:
            e1, e2, l1, l2 = e2, e1, l2, l1
        return cls(rect[0], e1 / l1, e2 / l2, l1, l2)

    def local(self, p: np.ndarray) -> np.ndarray:
        """(s along u, t along v) [m] of plan points (..., 2)."""
        d = np.asarray(p, float) - self.corner
        return np.stack([d @ self.u, d @ self.v], axis=-1)

    def plan(self, st: np.ndarray, end: int) -> np.ndarray:
        """Plan points of (s, t) measured from ``end`` (0: s = 0, 1: s = L, mirrored)."""
        st = np.asarray(st, float)
        s = st[..., 0] if end == 0 else self.length - st[..., 0]
        return self.corner + s[..., None] * self.u + st[..., 1:2] * self.v


def _door_end(box: _Box, jambs: np.ndarray) -> int:
    """Which end of the box (0 or 1) a door opens into, by its centre."""
    return int(box.local(jambs.mean(axis=0))[0] > box.length / 2)


def _landing_depth(box: _Box, end: int, doors: list[tuple[str, np.ndarray]]) -> float:
    """Landing depth [m] at ``end`` that takes in that end's doors (and 0.3 m beyond)."""
    depth = MIN_LANDING
    for _, jambs in doors:
        if _door_end(box, jambs) != end:
            continue
        s = box.local(jambs)[:, 0]
        s = s if end == 0 else box.length - s
        depth = max(depth, float(s.max()) + 0.3)
    return depth


def _ends(box: _Box, slices: list[StairwellSlice]) -> tuple[list[int], list[str]]:
    """Landing end per slice and how each was decided."""
    votes: list[int | None] = []
    for sl in slices:
        ends = [_door_end(box, j) for _, j in sl.doors]
        ones = sum(ends)
        votes.append(None if 2 * ones == len(ends) else int(2 * ones > len(ends)))
    how = ["by its doors" if v is not None else "" for v in votes]
    out = list(votes)
    for k in range(len(out)):               # undecided: the floor below, then above
        if out[k] is None:
            below = next((out[j] for j in range(k - 1, -1, -1) if out[j] is not None), None)
            above = next((votes[j] for j in range(k + 1, len(out)) if votes[j] is not None), None)
            out[k] = below if below is not None else above
            how[k] = ("as on the floor below" if below is not None else
                      "as on the floor above" if above is not None else "")
    if all(e is None for e in out):
        out = [0] * len(out)
        how = ["no door decides: first end of the box"] * len(out)
    return [int(e) for e in out], how


def _steps(rise: float) -> tuple[int, float]:
    """(number of risers, going [m]) for a rise [m]."""
    n = max(1, math.ceil(rise / MAX_RISER - 1e-9))
    going = min(MAX_GOING, max(MIN_GOING, STEP_RULE - 2 * rise / n))
    return n, going


def _fmt(p: np.ndarray) -> str:
    return f"({p[0]:.2f}, {p[1]:.2f})"


@dataclass
class _Door:
    """A stairwell door in the box frame (s from the landing end): id, spans along s and
    t [m], and its wall: ``end0``/``end1`` (the ends), ``side0``/``side1`` (t = 0 / W)."""

    id: str
    s: tuple[float, float]
    t: tuple[float, float]
    wall: str


def _doors(box: _Box, sl: StairwellSlice, end: int) -> list[_Door]:
    out = []
    for ident, jambs in sl.doors:
        st = box.local(jambs)
        if end == 1:
            st[:, 0] = box.length - st[:, 0]
        c = st.mean(axis=0)
        gaps = {"end0": c[0], "end1": box.length - c[0], "side0": c[1], "side1": box.width - c[1]}
        out.append(_Door(ident, (float(st[:, 0].min()), float(st[:, 0].max())),
                         (float(st[:, 1].min()), float(st[:, 1].max())), min(gaps, key=gaps.get)))
    return out


def _band(W: float, doors: list[_Door], s_lo: float, s_hi: float, at_far_end: bool,
          flights: int) -> tuple[float, float]:
    """(t of the band's low edge, band width) [m] for the flights: along the long side
    that lets them be widest without covering a door."""
    def widest(side: int) -> float:
        near, far = ("side0", "side1") if side == 0 else ("side1", "side0")
        w = min(W, flights * MAX_FLIGHT_WIDTH)
        for d in doors:
            t_lo = d.t[0] if side == 0 else W - d.t[1]
            along = d.s[1] > s_lo and d.s[0] < s_hi
            if d.wall == near and along:
                return 0.0
            if d.wall == "end1" and at_far_end:
                w = min(w, t_lo - DOOR_MARGIN)
            if d.wall == far and along:
                w = min(w, W - MIN_FLIGHT_WIDTH)
        return w

    w0, w1 = widest(0), widest(1)
    crowd = [sum(d.wall == f"side{k}" for d in doors) for k in (0, 1)]
    side = 0 if (w0, -crowd[0]) >= (w1, -crowd[1]) else 1
    w = max(w0 if side == 0 else w1, min(W, flights * MIN_FLIGHT_WIDTH))
    return (0.0 if side == 0 else W - w), w


def _layout(box: _Box, lo: StairwellSlice, hi: StairwellSlice, e_lo: int, e_hi: int,
            rise: float, band: tuple[float, float] | None = None):
    """(walking line (K, 2), footprint ring (4, 2), flight width, risers, going, kind,
    band), in (s, t) from the bottom's landing end; None if the box is too short.
    ``band`` (t of its low edge, width [m]) fixes where the flights go; by default the
    side and width that keep every door clear."""
    n, going = _steps(rise)
    L, W = box.length, box.width
    d_lo, d_hi = _doors(box, lo, e_lo), _doors(box, hi, e_lo)
    if e_lo == e_hi:                       # U-shaped: landing, flight, half landing, flight
        a = max(_landing_depth(box, e_lo, lo.doors), _landing_depth(box, e_lo, hi.doors))
        treads = math.ceil(n / 2)
        avail = L - a - MIN_HALF_LANDING
        if avail < treads * 0.1:
            return None
        going = min(going, avail / treads)
        run = treads * going
        t0, band = band or _band(W, d_lo + d_hi, a, L, True, 2)
        flight = band / 2
        # The half landing as deep as a flight is wide where there is room; what is
        # left over deepens the landing at the doors (level floor).
        half = min(max(MIN_HALF_LANDING, flight), L - a - run)
        a = L - run - half
        inner, outer = (t0 + 1.5 * flight, t0 + 0.5 * flight) if t0 > 0 else (t0 + 0.5 * flight, t0 + 1.5 * flight)
        t1, t2 = (inner, outer) if band < W else (outer, inner)
        turn = a + run + half / 2
        path = np.array([[a, t1], [a + run, t1], [turn, t1], [turn, t2], [a + run, t2], [a, t2]])
        foot = np.array([[a, t0], [L, t0], [L, t0 + band], [a, t0 + band]])
        return path, foot, flight, n, going, "U-shaped stair", (t0, band)
    a = _landing_depth(box, e_lo, lo.doors)                # straight: bottom landing, flight,
    b = _landing_depth(box, 1 - e_lo, hi.doors)            # top landing at the far end
    avail = L - a - b
    if avail < n * 0.1:
        return None
    going = min(going, avail / n)
    run = n * going
    a += (avail - run) / 2
    t0, band = (band[0], band[1] / 2) if band else _band(W, d_lo + d_hi, a, a + run, False, 1)
    path = np.array([[a, t0 + band / 2], [a + run, t0 + band / 2]])
    foot = np.array([[a, t0], [a + run, t0], [a + run, t0 + band], [a, t0 + band]])
    return path, foot, band, n, going, "straight flight", (t0, 2 * band)


def _unreached(box: _Box, sl: StairwellSlice, foot: Polygon, end: np.ndarray) -> list[str]:
    """Doors of ``sl`` that open onto the stair or whose side of it does not hold the
    stair end ``end`` on that floor (plan point where one steps on or off)."""
    free = shapely.make_valid(sl.polygon.difference(foot.buffer(0.05)))
    parts = [p for p in shapely.get_parts(free) if p.area > 0]
    home = next((p for p in parts if p.distance(shapely.Point(end)) < 0.05), None)
    out = []
    for ident, jambs in sl.doors:
        c = jambs.mean(axis=0)
        inward = box.corner + box.u * box.length / 2 + box.v * box.width / 2 - c
        probe = shapely.Point(c + 0.45 * inward / max(np.linalg.norm(inward), 1e-9))
        if home is None or home.distance(probe) > 0.05:
            out.append(ident)
    return out


def stairwell_stairs(name: str, slices: list[StairwellSlice]) -> tuple[list[dict], list[str]]:
    """Native stair features joining each pair of consecutive floors the stairwell
    ``name`` serves (``slices`` in any order), and the notes that explain them."""
    slices = sorted(slices, key=lambda s: s.floor)
    notes: list[str] = []
    if len(slices) < 2:
        return [], [f"stairwell {name} is on floor {slices[0].floor} only: no stair"] if slices else []
    box = _Box.of(slices[0].polygon)
    fill = slices[0].polygon.area / (box.length * box.width)
    if fill < 0.9:
        notes.append(f"stairwell {name} is not rectangular ({fill:.0%} of its bounding box): "
                     "its stairs are laid out in the box and clipped to the outline")
    ends, how = _ends(box, slices)
    pairs = []
    for lo, hi, e_lo, e_hi, how_lo, how_hi in zip(slices, slices[1:], ends, ends[1:], how, how[1:]):
        if hi.floor != lo.floor + 1:
            notes.append(f"stairwell {name} skips from floor {lo.floor} to {hi.floor}: no stair")
        elif not hi.z > lo.z:
            notes.append(f"stairwell {name}: floor {hi.floor} is not above floor {lo.floor}: "
                         "no stair")
        else:
            pairs.append((lo, hi, e_lo, e_hi, how_lo, how_hi))
    # Stacked flights share one band (in two-flight widths): the narrowest any pair's
    # doors allow, on the side most pairs take.
    bands = [got[-1] for lo, hi, e_lo, e_hi, *_ in pairs
             if (got := _layout(box, lo, hi, e_lo, e_hi, hi.z - lo.z)) is not None]
    shared = None
    if bands and len({round(b[0] + b[1] / 2 > box.width / 2) for b in bands}) == 1:
        w = min(b[1] for b in bands)
        shared = (0.0, w) if bands[0][0] == 0.0 else (box.width - w, w)
    feats = []
    for lo, hi, e_lo, e_hi, how_lo, how_hi in pairs:
        sid = f"stair_{name}_{lo.floor}_{hi.floor}"
        rise = hi.z - lo.z
        got = _layout(box, lo, hi, e_lo, e_hi, rise, shared)
        if got is None:
            notes.append(f"stairwell {name} ({box.length:.2f} x {box.width:.2f} m) is too "
                         f"small for a stair: floors {lo.floor} and {hi.floor} are not joined")
            continue
        path_st, foot_st, width, n, going, kind, _ = got
        path = box.plan(path_st, e_lo)
        foot = Polygon(box.plan(foot_st, e_lo))
        if fill < 0.9:
            foot = foot.intersection(slices[0].polygon)
        feats.append({"type": "Feature", "geometry": {"type": "LineString", "coordinates":
                                                      np.round(path, 4).tolist()},
                      "properties": {"kind": "stair", "floor": lo.floor, "id": sid,
                                     "floor_to": hi.floor, "width": round(width, 4),
                                     "n_steps": n,
                                     "footprint": np.round(np.asarray(
                                         shapely.get_exterior_ring(foot).coords), 4).tolist()}})
        decided = f"landing on floor {lo.floor} {how_lo}, on floor {hi.floor} {how_hi}"
        notes.append(f"stair {sid}: {kind} in stairwell {name} ({box.length:.2f} x "
                     f"{box.width:.2f} m), bottom on floor {lo.floor} at {_fmt(path[0])}, top "
                     f"on floor {hi.floor} at {_fmt(path[-1])} ({decided}); {n} risers of "
                     f"{rise / n:.3f} m, going {going:.2f} m, flight width {width:.2f} m")
        step_on = path[0] - 0.5 * (path[1] - path[0]) / np.linalg.norm(path[1] - path[0])
        step_off = path[-1] + 0.35 * (path[-1] - path[-2]) / np.linalg.norm(path[-1] - path[-2])
        for sl, end, which in ((lo, step_on, "bottom"), (hi, step_off, "top")):
            cut = _unreached(box, sl, foot, end)
            if cut:
                notes.append(f"stairwell {name} floor {sl.floor}: door(s) {', '.join(cut)} do "
                             f"not reach the {which} of stair {sid} (no room beside the flights)")
    return feats, notes
