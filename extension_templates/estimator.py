"""Extension template for a firenav ESTIMATOR: measurements in, poses with covariance out.

How to use it:

1. Copy this file into your package and rename the class ``<Algorithm>Estimator``;
   work through the ``TODO`` markers.
2. Register it: ``"estimator.my_dead_reckoning" = "acme_firenav.estimator:MyEstimator"``
   under ``[project.entry-points."firenav.plugins"]`` in your ``pyproject.toml``.
3. Test it with ``firenav_framework.testing.check_plugin(MyEstimator)``.

As it is, the class is a working example: plain dead reckoning of INS odometry
(each step's displacement added up, the covariance growing with the distance walked),
and it passes ``check_plugin``.

The contract (``firenav_framework/contract/estimator.py``):

* Input: measurements and/or another estimator's output (INS ``Odometry`` feeds the
  particle filter, the EKF, ...), in time order; plus ``Tick`` messages every
  ``tick_period(params)`` seconds if that returns a period.
* Output: ``PoseEstimate`` per firefighter with a covariance over (x, y, z, heading)
  that matches the real error; ``frame="building"`` once placed in the building, else
  the estimator's own frame name (``"odometry"``).
* The start pose of every estimator is the one ``StartPose`` model (parameter
  ``start``); SI units, radians.
* Constraints: list the capability bases it calls in ``accepts`` (from
  ``firenav_framework.capabilities``); attached constraints are in
  ``self.constraints``.
* Bad input is counted and skipped, never raised; per-firefighter state in
  ``PerAgent`` so ``reset(agent)`` forgets exactly one firefighter.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from firenav_framework import (Estimator, Message, Odometry, Params, PerAgent, PoseEstimate,
                               StartPose, param)
from firenav_framework.geometry import Rigid2D, wrap_angle


@dataclass
class _Track:
    """One firefighter's state. TODO: whatever your estimator keeps per firefighter."""

    transform: Rigid2D | None = None     # odometry frame -> output frame
    position: np.ndarray = field(default_factory=lambda: np.zeros(3))   # [m]
    heading: float = 0.0                 # [rad]
    cov: np.ndarray = field(default_factory=lambda: np.zeros((4, 4)))
    t: float = -math.inf                 # time of the last step [s]


class MyEstimator(Estimator):
    """Dead reckoning: INS odometry steps added up, the uncertainty growing with distance."""

    # TODO: the name pipelines use; unique among estimators.
    name = "my_dead_reckoning"
    # TODO: the message types it accepts and the ports it publishes.
    inputs = (Odometry,)
    outputs = {"pose": PoseEstimate}
    # TODO: the constraint capabilities it calls (e.g. (OdometryCorrection,)); none here.
    accepts = ()

    class Params(Params):
        # TODO: your parameters (nested Params models for groups: `start` is one).
        start: StartPose = param(StartPose(mode="unknown"))
        """where each firefighter starts (modes 'pose' and 'unknown' here)"""
        drift_per_m: float = param(0.05, unit="m/m", ge=0)
        """position error (1 sigma) added per metre walked"""

    def __init__(self, params: Params, ctx):
        super().__init__(params, ctx)
        # Refuse what this estimator cannot do when the pipeline is built, not mid-run.
        if params.start.mode not in ("pose", "unknown"):
            raise ValueError(f"start mode {params.start.mode!r} is not supported: use 'pose' "
                             f"or 'unknown'")
        self._tracks: PerAgent[_Track] = PerAgent(lambda agent: _Track())

    def handle(self, stream: str, msg: Message) -> None:
        # TODO: your estimator's update for one message (in time order).
        if not isinstance(msg, Odometry):
            self.ctx.count("ignored_messages")
            return
        if not (np.isfinite(msg.delta).all() and np.isfinite(msg.position).all()
                and math.isfinite(msg.heading) and np.isfinite(msg.cov).all()):
            self._skip(msg, "bad_odometry", "odometry steps with NaN or infinite values")
            return
        track = self._tracks[msg.agent]
        if msg.t <= track.t:
            self._skip(msg, "out_of_order", "odometry steps older than the last one")
            return
        if track.transform is None:
            track.transform = self._start(msg, track)
        step = track.transform.rotate(np.asarray(msg.delta, float))
        track.position = track.position + step
        track.heading = wrap_angle(track.transform.angle + msg.heading)
        grow = (self.params.drift_per_m * float(np.hypot(step[0], step[1]))) ** 2
        track.cov = track.cov + np.diag([grow, grow, grow, float(msg.cov[3, 3])])
        track.t = msg.t
        known = self.params.start.mode == "pose"
        self.ctx.publish("pose", PoseEstimate(
            t=msg.t, agent=msg.agent, device=msg.device, position=track.position.copy(),
            heading=track.heading, cov=track.cov.copy(),
            frame="building" if known else "odometry"))

    def _start(self, first: Odometry, track: _Track) -> Rigid2D:
        """The odometry-to-output transform, from the start pose of ``first.agent``."""
        before = np.asarray(first.position, float) - np.asarray(first.delta, float)
        heading0 = wrap_angle(first.heading - first.dheading)
        start = self.params.start
        position, heading = start.pose_of(first.agent)
        if start.mode == "unknown" or position is None:
            track.position = before.copy()
            return Rigid2D()
        heading = heading0 if heading is None else heading
        s = start.sigma_position ** 2
        track.position = np.asarray(position, float).copy()
        track.cov = np.diag([s, s, s, start.sigma_heading ** 2])
        return Rigid2D.mapping(before, heading0, track.position, heading)

    def _skip(self, msg: Message, code: str, text: str) -> None:
        self.ctx.count(code)
        self.ctx.report(msg.t, code, f"{text} skipped", agent=msg.agent, key=msg.agent)

    def reset(self, agent: str) -> None:
        # TODO: forget everything about this firefighter.
        self._tracks.reset(agent)
