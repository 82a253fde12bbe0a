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
  The flight width is the box width (half of it for each flight of a U).
* The landing at the door end is :data:`MIN_LANDING` deep, or deeper to take in every
  door of that end that opens onto the long sides; the half landing of a U is as deep
  as a flight is wide (at least :data:`MIN_HALF_LANDING`), and what the box has left
  over deepens the landing at the doors.

The result is a native stair feature (walking line from bottom to top, ``floor_to``,
``width``, ``n_steps`` and its ``footprint``) and a note saying how it was laid out and
which doors open away from the landing.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import shapely
from shapely.geometry import Polygon

__all__ = ["StairwellSlice", "stairwell_stairs", "MAX_RISER", "STEP_RULE", "MIN_GOING",
           "MAX_GOING", "MIN_LANDING", "MIN_HALF_LANDING"]

#: Highest riser [m] a laid-out stair gets.
MAX_RISER = 0.19
#: Comfort rule (Blondel): twice the riser plus the going [m].
STEP_RULE = 0.63
#: Goings [m] a laid-out stair keeps to while the stairwell is long enough.
MIN_GOING, MAX_GOING = 0.22, 0.30
#: Depth [m] of the landing at the door end, and of the half landing of a U-shaped stair.
MIN_LANDING = 1.2
MIN_HALF_LANDING = 1.0
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
    feats = []
    for lo, hi, e_lo, e_hi, how_lo, how_hi in zip(slices, slices[1:], ends, ends[1:], how, how[1:]):
        sid = f"stair_{name}_{lo.floor}_{hi.floor}"
        if hi.floor != lo.floor + 1:
            notes.append(f"stairwell {name} skips from floor {lo.floor} to {hi.floor}: no stair")
            continue
        rise = hi.z - lo.z
        if not rise > 0:
            notes.append(f"stairwell {name}: floor {hi.floor} is not above floor {lo.floor}: "
                         "no stair")
            continue
        got = _layout(box, lo, hi, e_lo, e_hi, rise)
        if got is None:
            notes.append(f"stairwell {name} ({box.length:.2f} x {box.width:.2f} m) is too "
                         f"small for a stair: floors {lo.floor} and {hi.floor} are not joined")
            continue
        path_st, foot_st, width, n, going, kind = got
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
        for sl, end in ((lo, e_lo), (hi, e_hi)):
            away = [d for d, j in sl.doors if _door_end(box, j) != end]
            if away:
                notes.append(f"stairwell {name} floor {sl.floor}: door(s) {', '.join(away)} "
                             f"open at the far end from the landing of stair {sid}")
    return feats, notes


def _layout(box: _Box, lo: StairwellSlice, hi: StairwellSlice, e_lo: int, e_hi: int,
            rise: float):
    """(walking line (K, 2), footprint ring (4, 2), flight width, risers, going, kind),
    in (s, t) from the bottom's landing end; None if the box is too short."""
    n, going = _steps(rise)
    L, W = box.length, box.width
    if e_lo == e_hi:                       # U-shaped: landing, flight, half landing, flight
        a = max(_landing_depth(box, e_lo, lo.doors), _landing_depth(box, e_lo, hi.doors))
        treads = math.ceil(n / 2)
        avail = L - a - MIN_HALF_LANDING
        if avail < treads * 0.1:
            return None
        going = min(going, avail / treads)
        run = treads * going
        # The half landing as deep as a flight is wide where there is room; what is
        # left over deepens the landing at the doors (level floor).
        half = min(max(MIN_HALF_LANDING, W / 2), L - a - run)
        a = L - run - half
        door_t = [box.local(j.mean(axis=0))[1] for _, j in lo.doors]
        t1, t2 = (W / 4, 3 * W / 4) if not door_t or np.mean(door_t) <= W / 2 else (3 * W / 4, W / 4)
        turn = a + run + half / 2
        path = np.array([[a, t1], [a + run, t1], [turn, t1], [turn, t2], [a + run, t2], [a, t2]])
        foot = np.array([[a, 0.0], [L, 0.0], [L, W], [a, W]])
        return path, foot, W / 2, n, going, "U-shaped stair"
    a = _landing_depth(box, e_lo, lo.doors)                # straight: bottom landing, flight,
    b = _landing_depth(box, 1 - e_lo, hi.doors)            # top landing at the far end
    avail = L - a - b
    if avail < n * 0.1:
        return None
    going = min(going, avail / n)
    run = n * going
    a += (avail - run) / 2
    path = np.array([[a, W / 2], [a + run, W / 2]])
    foot = np.array([[a, 0.0], [a + run, 0.0], [a + run, W], [a, W]])
    return path, foot, W, n, going, "straight flight"
