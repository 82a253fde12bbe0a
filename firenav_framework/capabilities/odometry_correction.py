"""The "odometry correction" capability: constraints that correct dead-reckoned steps.

A constraint for the ``dead_reckoning`` estimator subclasses :class:`OdometryCorrection`
and is attached under it in the pipeline. For every INS step of every firefighter the
estimator maps the step into the building frame with its current *update matrix* (the
INS-to-building :class:`~firenav_framework.geometry.Rigid2D`, ORCA paper eq. 8-9) and
calls :meth:`OdometryCorrection.correct` of each attached constraint in pipeline order
with an :class:`OdometryStep`; each sees the previous one's result. A constraint answers
None (leave the step as proposed) or a :class:`StepCorrection`: the corrected position,
optionally an update composed after the current transform (it moves this and every
later step), whether the correction teleports the firefighter (``jump``), and what the
constraint knows about the corrected position (``cov``, a measurement covariance the
estimator fuses into its own: tight across a wall the step touched, loose along it).

Constraints keep per-agent state of their own and implement ``reset(agent)``.
"""
from __future__ import annotations

from abc import abstractmethod
from dataclasses import dataclass

import numpy as np

from ..contract.constraint import Constraint
from ..geometry import Rigid2D
from ..messages import Odometry

__all__ = ["OdometryStep", "StepCorrection", "OdometryCorrection", "UNKNOWN_VARIANCE"]

#: Variance [m^2] standing for "this direction is not measured" in a measurement
#: covariance (a 1 km sigma): the estimator skips such directions.
UNKNOWN_VARIANCE = 1e6


@dataclass(frozen=True)
class OdometryStep:
    """One INS step as a constraint sees it (building frame, ENU metres, seconds).

    ``prev`` (3,) is the corrected position before the step; ``proposed`` (3,) where
    the step leads under the current update matrix ``transform`` (INS frame ->
    building frame); ``ins_position`` (3,) the integrated INS position in its own frame;
    ``dt`` [s] the time since the previous step; ``heading`` the proposed building-frame
    heading [rad]; ``odometry`` the INS message itself; ``cov`` (2, 2) [m^2], when the
    estimator keeps one, the covariance of the horizontal error of ``prev`` (ENU).
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
    cov: np.ndarray | None = None


@dataclass(frozen=True)
class StepCorrection:
    """A constraint's answer: the corrected ``position`` (3,) [m] after the step and an
    optional ``update`` composed after the current transform (it moves this and every
    later step). ``jump`` True marks a correction that teleports the agent (door or
    reset rules), which downstream filters should treat as uncertain. ``event`` names
    the rule that fired (counted in the run summary).

    ``cov`` (2, 2) [m^2], optional: the covariance of the horizontal error of
    ``position`` from this constraint's own evidence (the map or the radio, never the
    odometry), ENU; a direction it does not measure has variance
    :data:`UNKNOWN_VARIANCE`. The estimator fuses it as a
    measurement of the position (Kalman update, Joseph form), so its covariance shrinks
    where the constraint knows the position. ``independent`` False says the evidence
    repeats from step to step (the same wall touched again): the estimator then only
    brings its covariance down *to* ``cov`` along each of its axes, never below it.
    Ignored on a ``jump``.

    ``explained`` True says the move from ``OdometryStep.proposed`` to ``position`` is a
    Kalman update on the evidence in ``cov`` (a filter of UWB ranges), which the fusion
    of ``cov`` accounts for. False (a rule moved the position: walls that hold, slide or
    turn the step): the move may be wrong while the odometry is right (a wrong
    compartment, a wall the plan lacks), and the estimator widens its covariance along
    it (``dead_reckoning``'s ``drift.correction_doubt``)."""

    position: np.ndarray
    update: Rigid2D | None = None
    jump: bool = False
    event: str = ""
    cov: np.ndarray | None = None
    independent: bool = True
    explained: bool = False


class OdometryCorrection(Constraint, capability=True):
    """Base of constraints that correct dead-reckoned steps in the building frame."""

    hooks = ("correct",)

    @abstractmethod
    def correct(self, step: OdometryStep) -> StepCorrection | None:
        """Return a correction of this step, or None to leave it as proposed."""
