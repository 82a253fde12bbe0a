"""Parameters of ``team_fusion``: how old an input may be and how its age is paid for,
the consistency gate, the floor vote and the integrity group."""
from __future__ import annotations

from firenav_framework import Angle, Params, param
from firenav_framework.integrity import IntegrityParams


class Propagation(Params):
    """How an input's last pose is carried to the fusion time along the odometry."""

    max_age: float = param(10.0, unit="s", gt=0)
    """an input pose older than this (measurement time) is left out of the fusion"""
    per_metre: float = param(0.05, unit="m/m", ge=0)
    """position noise (1 sigma) added per metre the input is carried along the odometry"""
    per_second: float = param(0.05, unit="m/sqrt(s)", ge=0)
    """position noise random walk over the input's age"""
    max_speed: float = param(3.0, unit="m/s", gt=0)
    """without odometry to carry an input, its age is paid for as this speed times the age (1
    sigma)"""
    wait_for: float = param(1.5, unit="s", ge=0)
    """a step is fused once every input whose last pose is at most this much older than the step
    before has sent its pose of this step (or at the next step); 0: the inputs that answered the
    step before"""
    heading_sigma_max: Angle = param(0.35, unit="rad", gt=0)
    """an input's heading is used to turn the odometry's steps into its frame only while its
    1-sigma heading is below this"""


class Gate(Params):
    """The chi-square consistency gate between two inputs."""

    probability: float = param(0.999, gt=0.5, lt=1.0)
    """two inputs whose difference lies beyond this quantile of the chi-square distribution (2
    degrees of freedom, both covariances) contradict each other"""


class FloorVote(Params):
    """The floor by vote of the inputs (and the barometer, if there is one)."""

    barometer_weight: float = param(1.5, ge=0)
    """votes of the barometer's floor (each fused input that names a floor has one)"""
    barometer_max_age: float = param(5.0, unit="s", gt=0)
    """a barometer height older than this does not vote"""


class InputSettings(Params):
    """What the fusion assumes of one input stream."""

    inflate: float = param(1.0, ge=1.0)
    """factor on the input's covariance (an input whose covariance is known to be optimistic)"""
    floor: bool = param(True)
    """the input's floor votes and is checked by the gate (false: an input without floor evidence
    of its own)"""
    position: bool = param(True)
    """the input's position, height and heading are fused (false: only its floor votes; for an
    input every other one integrates already, such as INS alone, which is no independent witness
    of where the firefighter is but has floor evidence of its own)"""


class Support(Params):
    """Redundancy behind a trusted pose: how many inputs must each vouch for it."""

    inputs: int = param(2, ge=1)
    """a fused pose is trusted only when at least this many of its fused inputs have on their own a
    protection radius within `radius` (one method alone is checked by nothing)"""
    radius: float = param(10.0, unit="m", gt=0)
    """an input's own protection radius (after `inflate` and its learned factor) up to which it
    vouches for the pose"""


class Quality(Params):
    """Each input's covariance factor learned online from its consistency with the others."""

    enabled: bool = param(True)
    """learn a covariance factor per firefighter and input from the input's disagreement with the
    other inputs"""
    time_constant: float = param(30.0, unit="s", gt=0)
    """time constant of the exponentially weighted mean of the disagreement"""
    margin: float = param(8.0, ge=1.0)
    """the factor is this times the mean disagreement (room for the disagreement's spread)"""
    max_factor: float = param(1e4, ge=1.0)
    """largest factor learned (and the largest disagreement counted from one step)"""


class TeamFusionParams(Params):
    inputs: dict[str, InputSettings] = param({})
    """per input stream (e.g. 'gen.pose'): covariance factor and whether its floor counts; streams
    not named take the defaults"""
    propagation: Propagation = param(Propagation())
    """carrying each input's last pose to the fusion time"""
    gate: Gate = param(Gate())
    """consistency gate between inputs"""
    floor: FloorVote = param(FloorVote())
    """the floor vote"""
    support: Support = param(Support())
    """redundancy needed for trust"""
    quality: Quality = param(Quality())
    """covariance factors learned online"""
    integrity: IntegrityParams = param(IntegrityParams())
    """when a fused pose is trusted"""
