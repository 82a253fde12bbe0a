"""Per-step cost of ``dead_reckoning`` with the bundled ORCA pipeline's constraints.

The whole step as the pipeline runs it: ``DeadReckoningEstimator.handle`` on one INS
odometry message (alignment done), mapping it into the building, calling
``anchor_range``, ``wall_follow`` and ``orca`` in turn, propagating the covariance
(with the drift states) and publishing the pose (protection radius, trusted) and the
corrected odometry. Steps: a walk of 1.3 m steps in 1 s along the middle of the bundled
``corridor`` plan's corridor and back, 3 deg of heading noise per step, so that the
walls are touched now and then; no ranges. Also INS alone (no constraints).

Compare two versions of the code in one run on one machine (e.g. this checkout and an
older one on ``PYTHONPATH``), never figures from different runs:

    .venv/bin/python benchmarks/bench_orca_dead_reckoning.py [--steps 3000] [--repeats 5]
"""
from __future__ import annotations

import argparse
import math
import time

import numpy as np

from firenav_framework import Odometry
from firenav_framework.building import bundled_plan, load_building
from firenav_framework.testing import make_component
from firenav_plugins.constraints.anchor_range import AnchorRangeConstraint
from firenav_plugins.constraints.orca import OrcaConstraint
from firenav_plugins.constraints.wall_follow import WallFollowConstraint
from firenav_plugins.estimators.dead_reckoning import DeadReckoningEstimator

START = (5.12, 8.40)
COV = np.diag([4e-4, 4e-4, 1e-4, 1e-5])


def corridor_walk(n: int, rng: np.random.Generator) -> list[Odometry]:
    """``n`` odometry messages: out along the corridor (x 5-35 m) and back, repeated."""
    msgs, pos, heading, x = [], np.zeros(3), 0.0, START[0]
    for k in range(n):
        turn = math.pi if (x > 34.0 and math.cos(heading) > 0) or \
            (x < 6.0 and math.cos(heading) < 0) else 0.0
        dh = turn + math.radians(3.0) * rng.standard_normal()
        heading += dh
        d = 1.3 * np.array([math.cos(heading), math.sin(heading), 0.0])
        x += d[0]
        pos = pos + d
        msgs.append(Odometry(t=k + 1.0, agent="ff1", device="ff1/imu", t_start=float(k),
                             delta=d, dheading=dh, cov=COV, position=pos.copy(),
                             heading=heading, motion="walk"))
    return msgs


def per_step(constraints: bool, msgs: list[Odometry], building) -> tuple[float, float]:
    """Wall and CPU seconds per step of ``handle`` over ``msgs``."""
    params = {"start": {"mode": "pose", "position": (*START, 0.0), "heading": 0.0},
              "imu_yaw_offset": {"angle": 0.0}}
    dr, _, _ = make_component(DeadReckoningEstimator, params, building=building)
    if constraints:
        for cls, p in ((AnchorRangeConstraint, {}), (WallFollowConstraint, {}),
                       (OrcaConstraint, {})):
            c, _, _ = make_component(cls, p, building=building)
            c.start()
            dr.constraints.append(c)
    dr.start()
    t0, c0 = time.perf_counter(), time.process_time()
    for m in msgs:
        dr.handle("odo", m)
    return (time.perf_counter() - t0) / len(msgs), (time.process_time() - c0) / len(msgs)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=3000)
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    building = load_building(bundled_plan("corridor"))
    msgs = corridor_walk(args.steps, np.random.default_rng(0))
    per_step(True, msgs[:50], building)          # compile the kernels
    for label, with_c in (("INS alone", False), ("anchor_range + wall_follow + orca", True)):
        wall, cpu = min(per_step(with_c, msgs, building) for _ in range(args.repeats))
        print(f"{label:36s} {wall * 1e6:8.1f} us/step wall, {cpu * 1e6:8.1f} CPU "
              f"(best of {args.repeats})")


if __name__ == "__main__":
    main()
