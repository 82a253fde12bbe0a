"""What happens to a breadcrumb once it is on the floor: a dud, kicked, burned, lost.

The dispensers decide where to drop from the radio world as it is at the moment of the
drop (:func:`.radio.simulate_dispensers`); afterwards each breadcrumb has a fate, drawn
per breadcrumb and seed from its dispenser's :class:`~.scenario.BreadcrumbFaults`:

* **dud**: it never transmits (broken in the drop);
* **kicked**: whenever a firefighter's body passes within ``KICK_RADIUS_M`` of it, with
  probability ``kick`` it slides 0.5-3 m along the way they walk (stopped short of a
  wall), and goes on transmitting from there: its true position changes, the position
  any estimator remembers does not;
* **burned**: inside a fire zone it dies 60-180 s after the fire reaches it;
* **lost**: it stops at a random time (``lost_per_min``: battery, water, crushed).

A breadcrumb stops at the earliest of its ends (``t_off``); the radio world then no
longer hears it nor hears through it.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .radio import Drop, Node

KICK_RADIUS_M = 0.7
#: How often the walkers' bodies are looked at for kicks [s].
KICK_CHECK_S = 0.5
BURN_DELAY_S = (60.0, 180.0)


@dataclass
class BreadcrumbFate:
    """``cause``: "" (works to the end), ``dud``, ``burned`` or ``lost``; ``t_off`` [s]
    when it stopped; ``moves``: (t [s], new position (3,) ENU) per kick."""

    node_id: str
    t_off: float = np.inf
    cause: str = ""
    moves: list[tuple[float, np.ndarray]] = field(default_factory=list)

    def node(self, drop: Drop) -> Node:
        """The radio node of this breadcrumb (a piecewise-still track when kicked)."""
        if not self.moves:
            return Node(drop.node_id, position=drop.position, floor=drop.floor, t_on=drop.t,
                        t_off=self.t_off)
        times = np.array([t for t, _ in self.moves])
        places = np.vstack([drop.position[None]] + [p[None] for _, p in self.moves])

        def track(t: np.ndarray):
            i = np.searchsorted(times, t, side="right")
            return places[i], np.full(len(t), drop.floor), np.full(len(t), np.nan)
        return Node(drop.node_id, floor=drop.floor, t_on=drop.t, t_off=self.t_off, track=track)

    def record(self) -> dict:
        """For the truth file."""
        return {"fate": self.cause or "ok", "t_off": None if np.isinf(self.t_off) else self.t_off,
                "kicks": [[round(t, 3), *np.round(p, 4).tolist()] for t, p in self.moves]}


def breadcrumb_fates(drops: list[Drop], faults: dict[str, object], walkers: dict[str, object],
                     fires: list, world, t_end: float, rng: np.random.Generator
                     ) -> dict[str, BreadcrumbFate]:
    """The fate of every drop. ``faults``: the dropping agent's BreadcrumbFaults (or
    None); ``walkers``: agent -> track function t -> (ground positions (N, 3), floors
    (N,), headings (N,)); ``fires``: the scenario's fire zones; ``world``: the building."""
    times = np.arange(0.0, t_end, KICK_CHECK_S)
    paths = {a: fn(times) for a, fn in walkers.items()}
    out: dict[str, BreadcrumbFate] = {}
    for d in drops:
        f = faults.get(d.agent)
        fate = BreadcrumbFate(d.node_id)
        out[d.node_id] = fate
        if f is None:
            continue
        ends = []
        if rng.uniform() < f.dud:
            ends.append((d.t, "dud"))
        if f.lost_per_min > 0:
            rate = -np.log1p(-min(f.lost_per_min, 0.999)) / 60.0
            ends.append((d.t + rng.exponential(1.0 / rate), "lost"))
        place = np.asarray(d.position, float)
        if f.kick > 0:
            fate.moves = _kicks(d, place, f, paths, times, world, rng)
        places = [(d.t, place)] + fate.moves
        if f.burn:
            for fire in fires:
                if fire.floor != d.floor:
                    continue
                for k, (t0, p) in enumerate(places):
                    t1 = places[k + 1][0] if k + 1 < len(places) else np.inf
                    if np.linalg.norm(p[:2] - np.asarray(fire.position)) <= fire.radius_m:
                        burn = max(t0, fire.start_s) + rng.uniform(*BURN_DELAY_S)
                        if burn < t1:
                            ends.append((burn, "burned"))
                            break
        if ends:
            t_off, cause = min(ends)
            if t_off < t_end:
                fate.t_off, fate.cause = float(t_off), cause
                fate.moves = [(t, p) for t, p in fate.moves if t < t_off]
    return out


def _kicks(d: Drop, place: np.ndarray, f, paths: dict, times: np.ndarray, world,
           rng: np.random.Generator) -> list[tuple[float, np.ndarray]]:
    """Every approach of a body within reach of the breadcrumb where it lies, in time
    order; each kicks it with probability ``f.kick``."""
    moves = []
    floor = world.floor(d.floor)
    t_last = d.t + 2.0              # the dropper steps away first
    while True:
        best = None
        for a in sorted(paths):
            pos, fl, _ = paths[a]
            near = (np.linalg.norm(pos[:, :2] - place[:2], axis=1) < KICK_RADIUS_M) \
                & (fl == d.floor)
            enter = np.flatnonzero(near & ~np.concatenate([[False], near[:-1]]) & (times > t_last))
            if enter.size and (best is None or times[enter[0]] < best[0]):
                best = (times[enter[0]], a, int(enter[0]))
        if best is None:
            return moves
        t, a, i = best
        t_last = t
        if rng.uniform() >= f.kick:
            continue
        pos = paths[a][0]
        step = pos[min(i + 1, len(pos) - 1), :2] - pos[max(i - 1, 0), :2]
        if np.linalg.norm(step) < 1e-6:
            continue
        to = place[:2] + step / np.linalg.norm(step) * rng.uniform(*f.kick_m)
        hit, frac, _ = floor.first_wall_hit(place[None, :2], to[None])
        if hit[0]:                  # it stops short of the wall
            back = 0.1 / max(np.linalg.norm(to - place[:2]), 1e-6)
            to = place[:2] + (to - place[:2]) * max(0.0, frac[0] - back)
        place = np.array([to[0], to[1], place[2]])
        moves.append((float(t), place))
