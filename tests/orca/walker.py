"""Scripted INS steps through ``dead_reckoning`` with odometry constraints attached.

Tests of the ORCA constraint and its companions walk hand-drawn floors: each step is a
building-frame vector, reported in an INS frame turned by an arbitrary yaw, so that a
rule that confused the two frames would fail.
"""
from __future__ import annotations

import math

import numpy as np

from firenav_framework import Odometry, Range
from firenav_framework.building import Building, Floor
from firenav_framework.registry import default_registry
from firenav_framework.testing import make_component
from firenav_plugins.constraints.orca import OrcaConstraint
from firenav_plugins.estimators.dead_reckoning import DeadReckoningEstimator

YAW = 1.1          # the INS frame's arbitrary yaw [rad]
COV = np.diag([1e-4, 1e-4, 1e-4, 1e-5])


def building(walls, doors=(), anchors=()) -> Building:
    """A one-floor building (floor at z = 0) from wall segments (K, 2, 2) [m]."""
    floor = Floor(index=0, z=0.0, height=3.0, walls=np.array(walls, float), doors=list(doors))
    return Building("test", [floor], anchors=list(anchors))


class Walker:
    """Feeds building-frame step vectors, as the INS (turned by YAW) would report them.

    ``orca``: parameters of an ORCA constraint to attach (None: none); ``extra``: further
    ``(constraint class, parameters)`` attached after it, in order.
    """

    def __init__(self, b: Building, start, heading, orca: dict | None = None,
                 agent: str = "ff1", chain=None, extra=()):
        params = {"start": {"mode": "pose", "position": (*start, 0.0), "heading": heading},
                  "imu_yaw_offset": {"angle": 0.0}}
        self.dr, self.rec, self.stats = chain or make_component(DeadReckoningEstimator, params,
                                                                building=b)
        self.constraints = []
        self.constraint_records = []      # what each constraint published (diagnostics)
        if chain is None:
            attach = ([] if orca is None else [(OrcaConstraint, orca)]) + list(extra)
            for cls, cparams in attach:
                c, c_rec, c_stats = make_component(cls, cparams, building=b)
                c.start()
                self.constraint_records.append(c_rec)
                self.dr.constraints.append(c)
                self.constraints.append((c, c_stats))
            self.dr.start()
        self.orca = self.constraints[0][0] if orca is not None and chain is None else None
        self.agent, self.t = agent, 0.0
        self.heading = heading - YAW     # INS-frame heading
        self.pos = np.zeros(3)

    def step(self, dx: float, dy: float, turn: float = 0.0, dt: float = 1.0) -> np.ndarray:
        c, s = math.cos(-YAW), math.sin(-YAW)
        d = np.array([c * dx - s * dy, s * dx + c * dy, 0.0])
        self.pos = self.pos + d
        self.heading += turn
        self.t += dt
        self.dr.handle("odo", Odometry(t=self.t, agent=self.agent, t_start=self.t - dt,
                                       delta=d, dheading=turn, cov=COV, position=self.pos.copy(),
                                       heading=self.heading))
        return self.rec.on("pose")[-1].position

    def range(self, anchor: str, r: float, sigma: float = 0.1, nlos: bool = False,
              dt: float = 0.0) -> None:
        """A range [m] to ``anchor``, ``dt`` [s] after the last step, to every constraint."""
        msg = Range(t=self.t + dt, agent=self.agent, a=self.agent, b=anchor, range_m=r,
                    sigma_m=sigma, nlos=nlos)
        for c, _ in self.constraints:
            c.handle("uwb", msg)

    def counts(self) -> dict:
        """Rule events counted by the estimator and the constraints."""
        out = dict(self.stats.counts.get("under_test", {}))
        for _, c_stats in self.constraints:
            out.update(c_stats.counts.get("under_test", {}))
        return out
