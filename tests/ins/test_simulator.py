"""A walk from the scenario simulator's gait model (another implementation of the foot's
physics than tests/ins/synthetic.py) is reproduced: footprints, stride count, gait labels."""
from __future__ import annotations

import math

import numpy as np

from firenav_framework.simulator import gait, imu_ideal
from firenav_plugins.estimators.zupt_ins import eskf
from firenav_plugins.estimators.zupt_ins.steps import StepTracker

from .conftest import run_engine


def _strides() -> "gait.StrideTable":
    rows, p, yaw, t = [], np.zeros(3), 0.0, 1.0
    for k in range(12):
        length, turn = (1.4, 0.4 if k in (2, 3) else 0.0) if k < 8 else (0.6, 0.0)
        dz = 0.34 if 8 <= k < 10 else (-0.34 if k >= 10 else 0.0)
        style = gait.UP if dz > 0 else gait.DOWN if dz < 0 else gait.LEVEL
        p1 = p + [length * math.cos(yaw + turn / 2), length * math.sin(yaw + turn / 2), dz]
        rows.append((t, t + 0.7, p, p1, yaw, yaw + turn, style))
        p, yaw, t = p1, yaw + turn, t + 1.2
    n = len(rows)
    col = lambda i: np.array([r[i] for r in rows])  # noqa: E731
    table = gait.StrideTable(
        t0=col(0), t1=col(1), p0=col(2), p1=col(3), yaw0=col(4), yaw1=col(5),
        pitch0=np.zeros(n), pitch1=np.zeros(n), roll0=np.zeros(n), roll1=np.zeros(n),
        clearance=np.full(n, 0.08), toe_off=np.full(n, 0.5), heel_strike=np.full(n, 0.3),
        roll_amp=np.full(n, 0.05), sway=np.full(n, 0.02), vstyle=col(6))
    table.check()
    return table


def test_simulated_walk_with_stairs_is_reproduced():
    table = _strides()
    t = np.arange(0.0, table.t1[-1] + 1.0, 1 / 200)
    accel, gyro = imu_ideal.ideal_imu(gait.foot_kinematics(table, t))
    res = run_engine(t, accel, gyro)
    steps = res.events[res.events[:, eskf.E_KIND] == eskf.EVENT_STEP]
    assert len(steps) == len(table)
    err = np.linalg.norm(steps[:, eskf.E_POS:eskf.E_POS + 3] - table.p1, axis=1)
    distance = np.sum(np.linalg.norm(table.p1 - table.p0, axis=1))
    assert err[-1] < 0.005 * distance, (err, distance)
    tracker = StepTracker()
    labels = [tracker.step(ev).motion for ev in steps]
    assert labels == ["walk"] * 8 + ["stairs_up"] * 2 + ["stairs_down"] * 2
