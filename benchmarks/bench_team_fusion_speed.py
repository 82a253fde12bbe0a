"""Per-step cost of team_fusion beside dead_reckoning's, in one run.

One firefighter, 2000 strides of 1 m; team_fusion gets the building-frame odometry and
five pose inputs per stride (consistent ones, and one of them 8 m off every tenth stride
so the gate and the rival-hypothesis path run too); dead_reckoning integrates the same
strides. Prints microseconds per stride for both (the machine is shared: compare the
two figures of one run, not runs with each other).

    python benchmarks/bench_team_fusion_speed.py
"""
from __future__ import annotations

import time

import numpy as np

from firenav_framework import Odometry, PoseEstimate
from firenav_framework.testing import Session
from firenav_plugins.estimators.dead_reckoning import DeadReckoningEstimator
from firenav_plugins.estimators.team_fusion import TeamFusionEstimator

STRIDES = 2000
INPUTS = ("dr.pose", "pf.pose", "mm.pose", "ekf.pose", "gen.pose")


def odometry(k: int) -> Odometry:
    t = float(k)
    return Odometry(t=t, agent="ff1", device="ff1/imu", t_start=t - 1.0,
                    delta=np.array([1.0, 0.0, 0.0]), dheading=0.0, cov=np.eye(4) * 1e-4,
                    position=np.array([t, 0.0, 0.0]), heading=0.0)


def pose(k: int, j: int, rng: np.random.Generator) -> PoseEstimate:
    off = 8.0 if (j == 4 and k % 10 == 0) else 0.0
    xy = np.array([k + off, 0.0]) + rng.normal(0.0, 0.3, 2)
    return PoseEstimate(t=float(k), agent="ff1", device="ff1/imu",
                        position=np.array([xy[0], xy[1], 0.0]), heading=0.0,
                        cov=np.diag([0.09 * (j + 1), 0.09 * (j + 1), 0.01, 0.01]), floor=0)


def main() -> None:
    rng = np.random.default_rng(0)
    fusion_msgs, odo_msgs = [], []
    for k in range(1, STRIDES + 1):
        fusion_msgs += [(s, pose(k, j, rng)) for j, s in enumerate(INPUTS)]
        fusion_msgs.append(("dr.odometry", odometry(k)))
        odo_msgs.append(("ins.odometry", odometry(k)))
    fusion = Session(TeamFusionEstimator, {}).start()
    dr = Session(DeadReckoningEstimator, {"start": {"mode": "unknown"}}).start()
    t0 = time.perf_counter()
    fusion.feed(fusion_msgs)
    t1 = time.perf_counter()
    dr.feed(odo_msgs)
    t2 = time.perf_counter()
    print(f"team_fusion (5 inputs): {1e6 * (t1 - t0) / STRIDES:8.1f} us per stride "
          f"({len(fusion.recorder.on('pose'))} poses)")
    print(f"dead_reckoning:         {1e6 * (t2 - t1) / STRIDES:8.1f} us per stride")


if __name__ == "__main__":
    main()
