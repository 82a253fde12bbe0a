"""The "odometry correction" capability: constraints that correct dead-reckoned steps.

A constraint for the ``dead_reckoning`` estimator subclasses :class:`OdometryCorrection`
and is attached under it in the pipeline. For every INS step of every firefighter the
estimator maps the step into the building frame with its current *update matrix* (the
INS-to-building :class:`~firenav_framework.geometry.Rigid2D`, ORCA paper eq. 8-9) and
calls :meth:`OdometryCorrection.correct` of each attached constraint in pipeline order
with an :class:`OdometryStep`; each sees the previous one's result. A constraint answers
None (leave the step as proposed) or a :class:`StepCorrection`: the corrected position,
optionally an update composed after the current transform (it moves this and every
later step), and whether the correction teleports the firefighter (``jump``).

Constraints keep per-agent state of their own and implement ``reset(agent)``.
"""
from __future__ import annotations

from abc import abstractmethod
from dataclasses import dataclass

import numpy as np

from ..contract.constraint import Constraint
from ..geometry import Rigid2D
from ..messages import Odometry

__all__ = ["OdometryStep", "StepCorrection", "OdometryCorrection"]


@dataclass(frozen=True)
class OdometryStep:
    """One INS step as a constraint sees it (building frame, ENU metres, seconds).

    ``prev`` (3,) is the corrected position before the step; ``proposed`` (3,) where
    the step leads under the current update matrix ``transform`` (INS frame ->
    building frame); ``ins_position`` (3,) the integrated INS position in its own frame;
    ``dt`` [s] the time since the previous step; ``heading`` the proposed building-frame
    heading [rad]; ``odometry`` the INS message itself.
    """

    agent: str
    t: float
    dt: float
    prev: np.ndarray
    proposed: np.ndarray
    heading: float
    transform: Rigid2D
    ins_position: np.ndarray
    odometry: Odometry


@dataclass(frozen=True)
class StepCorrection:
    """A constraint's answer: the corrected ``position`` (3,) [m] after the step and an
    optional ``update`` composed after the current transform (it moves this and every
    later step). ``jump`` True marks a correction that teleports the agent (door or
    reset rules), which downstream filters should treat as uncertain. ``event`` names
    the rule that fired (counted in the run summary)."""

    position: np.ndarray
    update: Rigid2D | None = None
    jump: bool = False
    event: str = ""


class OdometryCorrection(Constraint, capability=True):
    """Base of constraints that correct dead-reckoned steps in the building frame."""

    hooks = ("correct",)

    @abstractmethod
    def correct(self, step: OdometryStep) -> StepCorrection | None:
        """Return a correction of this step, or None to leave it as proposed."""
