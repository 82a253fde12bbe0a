"""How much a walker turned over its last two steps, from its INS odometry.

Shared by ``orca`` (no heading correction is stored during a turn) and ``wall_follow``
(a turn ends a straight run).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from firenav_framework.geometry import wrap_angle

__all__ = ["TurnHistory"]


@dataclass
class TurnHistory:
    """The turns of the previous two steps [rad] and the direction of the last real step.

    A turn shows in the INS heading change and in the change of direction between steps
    (a stride that rounds a corner lags the foot's heading); moves shorter than
    ``min_step`` [m] (shuffles while standing) have no direction.
    """

    turns: tuple[float, float] = (0.0, 0.0)
    course: float | None = None          # INS-frame direction of the last real step [rad]

    def update(self, delta: np.ndarray, dheading: float, min_step: float) -> float:
        """Add one step (INS-frame increment (2+,) [m], heading change [rad]); return the
        total turn [rad] over this step and the previous one."""
        turn = abs(dheading)
        if math.hypot(delta[0], delta[1]) >= min_step:
            course = math.atan2(delta[1], delta[0])
            if self.course is not None:
                turn = max(turn, abs(wrap_angle(course - self.course)))
            self.course = course
        self.turns = (self.turns[1], turn)
        return self.turns[0] + self.turns[1]
