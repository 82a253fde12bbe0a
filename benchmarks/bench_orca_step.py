"""Per-step cost of the ORCA constraint on a real floor, against RVO2 and a no-index scan.

Floor: the bundled ``office_loop`` plan (a 50 x 22 m office floor, 168 wall segments)
or any plan given with ``--plan``. Steps: a random walk that hugs the walls (the
firefighters' left-hand search), so that most steps touch a wall and ORCA has work to
do; each step is 1.3 m over 1.0 s.

Reported per step, in the same run:

* ours, kernel - :meth:`WallGrid.step` (one timer around each call): grid query of the walls near the agent,
  swept-disc collision check, ORCA half-planes, LP and the smallest rotation (one
  compiled call);
* ours, all walls - the same kernels given every wall of the floor (no spatial index),
  to show what the index buys;
* RVO2 - ``pyrvo`` (C++ RVO2 with its obstacle k-d tree): one ``do_step`` for one agent
  with the same walls as two-vertex obstacles (optional: ``pip install pyrvo``). Both
  core calls are timed the same way, one timer around each call: RVO2's agent position
  and velocities are set before its timer starts, as our kernel gets its inputs as
  arguments; the agreement of RVO2's new velocity with ours (within 1 cm/s) is printed
  beside;
* ours, constraint - :meth:`OrcaConstraint.correct` as ``dead_reckoning`` calls it,
  with the paper's rules and the update-matrix bookkeeping in Python;
* the bundled pipeline's companions on a continuous straight-ish walk (2 deg of
  heading noise per step) up and down the longest wall: ``wall_follow`` (its run of up to
  15 m of steps, the walls near it) and ``anchor_range`` with one range per step.

Run: ``.venv/bin/python benchmarks/bench_orca_step.py [--plan office_loop] [--steps 20000]``
"""
from __future__ import annotations

import argparse
import math
import os
import time

os.environ.setdefault("NUMBA_NUM_THREADS", "1")   # one thread on both sides

import numpy as np  # noqa: E402

from firenav_framework import Odometry, Range
from firenav_framework.building import bundled_plan, load_building
from firenav_framework.testing import make_component
from firenav_framework.capabilities import OdometryStep
from firenav_framework.geometry import Rigid2D
from firenav_plugins.constraints.anchor_range import AnchorRangeConstraint
from firenav_plugins.constraints.orca import OrcaConstraint
from firenav_plugins.constraints.orca.step_solver import WallGrid
from firenav_plugins.constraints.wall_follow import WallFollowConstraint

R, TAU, STEP, DT = 0.25, 2.0, 1.3, 1.0
NONE2, NONE1 = np.zeros((0, 2)), np.zeros(0)


def wall_hugging_steps(floor, n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """(n, 2) start points 0.2-0.6 m from a wall and (n, 2) targets one step on."""
    walls = floor.walls
    w = rng.integers(0, len(walls), n)
    a, b = walls[w, 0], walls[w, 1]
    u = rng.uniform(0, 1, (n, 1))
    e = b - a
    length = np.maximum(np.hypot(*e.T), 1e-9)[:, None]
    normal = np.column_stack([-e[:, 1], e[:, 0]]) / length
    side = rng.choice([-1.0, 1.0], (n, 1))
    start = a + u * e + side * normal * rng.uniform(0.2, 0.6, (n, 1))
    # mostly along the wall with a small heading error, sometimes into it
    along = e / length * rng.choice([-1.0, 1.0], (n, 1))
    ang = rng.normal(0, math.radians(15), n)
    c, s = np.cos(ang), np.sin(ang)
    d = np.column_stack([c * along[:, 0] - s * along[:, 1], s * along[:, 0] + c * along[:, 1]])
    return start, start + STEP * d


def tiled(building, n: int):
    """The building with its ground floor's walls repeated n x n times side by side."""
    from dataclasses import replace
    f = building.floors[0]
    lo, hi = f.walls.reshape(-1, 2).min(0), f.walls.reshape(-1, 2).max(0)
    span = hi - lo + 1.0
    walls = np.concatenate([f.walls + np.array([i * span[0], j * span[1]])
                            for i in range(n) for j in range(n)])
    floor = type(f)(index=0, z=f.z, height=f.height, walls=walls, doors=f.doors)
    return replace(building, floors=[floor])


def time_each_call(prepare, call, n: int, repeats: int = 3) -> tuple[float, float]:
    """Mean wall and CPU time [us] of ``call(i)`` alone, timers around each call,
    ``prepare(i)`` before they start; the best of ``repeats`` passes (the machine is
    shared)."""
    best = (math.inf, math.inf)
    wall, cpu = time.perf_counter_ns, time.process_time_ns
    for _ in range(repeats):
        total_w = total_c = 0
        for i in range(n):
            prepare(i)
            w0, c0 = wall(), cpu()
            call(i)
            total_c += cpu() - c0
            total_w += wall() - w0
        best = min(best, (total_w / n * 1e-3, total_c / n * 1e-3))
    return best


def time_per_call(fn, n: int, repeats: int = 3) -> float:
    """Mean time per call [us], the best of ``repeats`` passes (the machine is shared)."""
    best = math.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        for i in range(n):
            fn(i)
        best = min(best, (time.perf_counter() - t0) / n * 1e6)
    return best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plan", default="office_loop")
    ap.add_argument("--steps", type=int, default=20000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--tile", type=int, default=1, help="repeat the floor N x N times "
                    "(a campus-sized floor) to show how the cost scales with wall count")
    args = ap.parse_args()
    building = load_building(bundled_plan(args.plan))
    if args.tile > 1:
        building = tiled(building, args.tile)
    floor = building.floors[0]
    rng = np.random.default_rng(args.seed)
    p0, p1 = wall_hugging_steps(floor, args.steps, rng)
    print(f"plan {args.plan}: {len(floor.walls)} wall segments, {args.steps} steps "
          f"(r = {R} m, tau = {TAU} s, step {STEP} m / {DT} s)")

    grid = WallGrid(floor)
    grid.step(p0[0], p1[0], DT, R, TAU, TAU, NONE2, NONE2, NONE1)   # compile
    results = [grid.step(p0[i], p1[i], DT, R, TAU, TAU, NONE2, NONE2, NONE1)
               for i in range(args.steps)]
    touched = np.mean([r[0] != 0 for r in results])

    # the same kernels with one grid cell holding every wall: no spatial index
    flat = WallGrid(floor)
    flat.start = np.array([0, len(floor.walls)], dtype=np.int64)
    flat.items = np.arange(len(floor.walls), dtype=np.int64)
    big = float(np.abs(floor.walls).max()) * 4 + 100.0
    flat.grid = (-big, -big, 2 * big, 1, 1)
    brute = [flat.step(p0[i], p1[i], DT, R, TAU, TAU, NONE2, NONE2, NONE1)
             for i in range(args.steps)]
    same = np.mean([np.allclose(a[1], b[1]) and a[0] == b[0] for a, b in zip(results, brute)])
    allw = time_per_call(lambda i: flat.step(p0[i], p1[i], DT, R, TAU, TAU, NONE2, NONE2,
                                             NONE1), args.steps)

    def nothing(i: int) -> None:
        pass

    kernel = time_each_call(nothing, lambda i: grid.step(p0[i], p1[i], DT, R, TAU, TAU, NONE2,
                                                         NONE2, NONE1), args.steps)
    rvo = agree = None
    try:
        import pyrvo
    except ImportError:
        pyrvo = None
    if pyrvo is not None:
        sim = pyrvo.RVOSimulator()
        sim.set_time_step(DT)
        agent = sim.add_agent(tuple(p0[0]), 1.0, 0, TAU, TAU, R, STEP / DT, (0.0, 0.0))
        for a, b in floor.walls:
            sim.add_obstacle([tuple(a), tuple(b)])
        sim.process_obstacles()
        vel = (p1 - p0) / DT
        start = [tuple(p) for p in p0]
        want = [tuple(v) for v in vel]

        def rvo_inputs(i: int) -> None:
            sim.set_agent_position(agent, start[i])
            sim.set_agent_velocity(agent, want[i])
            sim.set_agent_pref_velocity(agent, want[i])

        rvo = time_each_call(rvo_inputs, lambda i: sim.do_step(), args.steps)
        chosen = []
        for i in range(args.steps):
            rvo_inputs(i)
            sim.do_step()
            chosen.append(sim.get_agent_velocity(agent).to_tuple())
        agree = np.mean(np.hypot(*(np.array(chosen) - np.array([r[1] for r in results])).T)
                        < 0.01)

    orca, _, _ = make_component(OrcaConstraint, {}, building=building)
    orca.start()
    odo = Odometry(t=1.0, agent="ff1", t_start=0.0, delta=np.zeros(3), dheading=0.0,
                   cov=np.eye(4) * 1e-4, position=np.zeros(3), heading=0.0)
    steps = [OdometryStep(agent="ff1", t=float(i + 1), dt=DT, prev=np.array([*p0[i], 0.0]),
                          proposed=np.array([*p1[i], 0.0]), heading=0.0, transform=Rigid2D(),
                          ins_position=np.zeros(3), odometry=odo) for i in range(args.steps)]
    orca.correct(steps[0])
    full = time_per_call(lambda i: orca.correct(steps[i]), args.steps)

    walk = companion_steps(floor, args.steps, rng)
    follow, _, _ = make_component(WallFollowConstraint, {}, building=building)
    follow.start()
    wf = time_per_call(lambda i: follow.correct(walk[i]), args.steps, repeats=1)
    anchor = np.array([*walk[0].prev[:2], 1.0])
    ranged, _, _ = make_component(AnchorRangeConstraint, {}, building=_with_anchor(building,
                                                                                   anchor))
    ranged.start()

    def range_step(i: int) -> None:
        s = walk[i]
        ranged.handle("uwb", Range(t=s.t - 0.5, agent="ff1", a="ff1/uwb", b="bench",
                                   range_m=float(np.hypot(*(s.prev[:2] - anchor[:2]))),
                                   sigma_m=0.1))
        ranged.correct(s)
    ar = time_per_call(range_step, args.steps, repeats=1)

    print(f"steps touching a wall: {100 * touched:.0f}%; grid and all-walls answers "
          f"identical: {100 * same:.1f}%")
    print(f"{'per step':<40}{'us':>8}   (kernel rows: wall / CPU, timers around each call)")
    print(f"{'ours, kernel (grid index)':<40}{kernel[0]:8.2f} / {kernel[1]:.2f}")
    print(f"{'RVO2 do_step':<40}" + (f"{rvo[0]:8.2f} / {rvo[1]:.2f}" if rvo else "   (n/a)")
          + (f"   (new velocity within 1 cm/s of ours on {100 * agree:.0f}% of steps)"
             if rvo else ""))
    print(f"{'ours, kernel (all walls)':<40}{allw:8.2f}")
    print(f"{'ours, OrcaConstraint.correct':<40}{full:8.2f}")
    print(f"{'ours, WallFollowConstraint.correct':<40}{wf:8.2f}")
    print(f"{'ours, AnchorRangeConstraint':<40}{ar:8.2f}")


def companion_steps(floor, n: int, rng: np.random.Generator) -> list[OdometryStep]:
    """A continuous walk of ``n`` steps 0.5 m beside the floor's longest wall, up and
    down it, its heading wandering 2 deg per step and pulled back along the wall (the
    INS frame is the building frame)."""
    lengths = np.hypot(*(floor.walls[:, 1] - floor.walls[:, 0]).T)
    a, b = floor.walls[int(np.argmax(lengths))]
    length = float(lengths.max())
    e = (b - a) / length
    base = math.atan2(e[1], e[0])
    pos = a + 0.5 * np.array([-e[1], e[0]])
    heading, steps = base, []
    for i in range(n):
        along = float((pos - a) @ e)
        if (along > length and math.cos(base - math.atan2(e[1], e[0])) > 0) or \
                (along < 0 and math.cos(base - math.atan2(e[1], e[0])) < 0):
            base, heading = base + math.pi, heading + math.pi       # turn at the end
        heading = base + 0.8 * (heading - base) + rng.normal(0, math.radians(2))
        d = STEP * np.array([math.cos(heading), math.sin(heading)])
        odo = Odometry(t=float(i + 1), agent="ff1", t_start=float(i), delta=np.array([*d, 0.0]),
                       dheading=0.0, cov=np.eye(4) * 1e-4, position=np.zeros(3), heading=heading)
        new = pos + d
        steps.append(OdometryStep(agent="ff1", t=float(i + 1), dt=DT, prev=np.array([*pos, 0.0]),
                                  proposed=np.array([*new, 0.0]), heading=heading,
                                  transform=Rigid2D(), ins_position=np.array([*new, 0.0]),
                                  odometry=odo))
        pos = new
    return steps


def _with_anchor(building, position: np.ndarray):
    from dataclasses import replace

    from firenav_framework.building import Anchor
    return replace(building, anchors=[Anchor("bench", "uwb", position, 0)])


if __name__ == "__main__":
    main()
