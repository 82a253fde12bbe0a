"""Parameters of ``dead_reckoning``: the start pose (with the first-segment heading), the
IMU-yaw to walking-direction offset, the per-step noise floors and gap bridging."""
from __future__ import annotations

import math

from pydantic import model_validator

from firenav_framework import Angle, AngularRate, Params, StartPose, param
from firenav_framework.integrity import IntegrityParams

from ..start_pose import missing_headings, start_pose_type


class FirstSegment(Params):
    """Heading from the first straight segment walked along a wall of known direction."""

    wall_heading: Angle | None = param(None, unit="rad")
    """building-frame direction of the first straight segment (a known wall); default: the start
    heading"""
    distance: float = param(3.0, unit="m", gt=0)
    """straight distance walked before the heading is fixed"""
    straightness: float = param(0.3, unit="m", gt=0)
    """largest sideways deviation from the chord that still counts as straight"""


class DeadReckoningStart(StartPose):
    """:class:`StartPose` with the ORCA paper's other way to the start heading: the first
    straight segment walked along a wall (``first_segment``); the position is that of the
    mode (``entrance``, ``pose`` or ``truth``)."""

    first_segment: FirstSegment | None = param(None)
    """take the start heading from the first straight segment walked (along a wall of direction
    first_segment.wall_heading) instead of the start pose"""

    @model_validator(mode="after")
    def _heading_known(self) -> "DeadReckoningStart":
        if self.mode == "pose" and self.first_segment is None and missing_headings(self):
            raise ValueError(f"start mode 'pose' needs a heading for "
                             f"{', '.join(missing_headings(self))} (or first_segment)")
        return self


DEFAULT_START = DeadReckoningStart()
Start = start_pose_type(DEFAULT_START, modes=("entrance", "pose", "truth", "unknown"),
                        needs_heading=False)


class ImuYawOffset(Params):
    """Walking direction minus the INS heading: the IMU's yaw on the boot plus the toe-out."""

    angle: Angle | None = param(None, unit="rad")
    """the offset, if known; null: estimated from the first straight steps"""
    steps: int = param(6, ge=1)
    """straight forward steps the estimate uses (the steps are held back until then)"""


class StepNoise(Params):
    """Least noise per step in the covariance, for what INS covariances tend to leave out."""

    heading_sigma: Angle = param(0.005, unit="rad", ge=0)
    """heading noise per step (INS heading drift)"""
    length_sigma: float = param(0.01, unit="1", ge=0)
    """position noise per step and axis, as a fraction of the step length"""


class Drift(Params):
    """Errors of the INS that stay with it from step to step, as states of the covariance.

    The per-step odometry covariance is white: it lets the heading wander as a random
    walk and the step lengths err independently. A foot INS's heading error grows
    linearly with time (the residual gyro bias about z) and its distance error linearly
    with distance (a stride-length scale error): both are carried as states, so the
    position covariance grows the way the track drifts. Each turn adds heading noise in
    proportion to its angle (the gyro's scale factor). An odometry whose heading variance
    per step implies a larger residual rate (an INS that knows it is uncalibrated) raises
    the rate state to it.
    """

    heading_rate_sigma: AngularRate = param(0.1 * math.pi / 180, unit="rad/s", ge=0)
    """1-sigma residual heading rate (gyro bias about z); at least the rate the odometry's own
    heading variance per step implies"""
    scale_sigma: float = param(0.03, ge=0, lt=1)
    """1-sigma step-length scale error (fraction)"""
    turn_sigma: float = param(0.03, ge=0, lt=1)
    """1-sigma heading error per radian turned (gyro scale factor, g-sensitivity), white from turn
    to turn"""
    contradiction_gate: float = param(13.8, gt=0)
    """a correction whose squared Mahalanobis distance from the odometry's prediction exceeds this
    (13.8: 99.9 % of a 2-D Gaussian) contradicts the odometry: reported, and the pose covariance
    widened by it"""
    correction_doubt: float = param(1.0, ge=0)
    """the share of a rule's correction (a move the walls made that no measurement explains:
    held, slid or turned; StepCorrection.explained False) added to the covariance along
    that move, as its squared length: the move may be wrong and the odometry right (a
    wrong compartment, a wall the plan lacks, a turn misread). 0: off"""


class DeadReckoningParams(Params):
    start: Start = param(DEFAULT_START)
    """how the INS frame is placed in the building (eq. 9): mode 'entrance' = the building
    entrance's position and inward heading; 'pose' = start position and heading; 'truth' = the
    pose of a GroundTruth input stream when the INS starts (a surveyed start, for evaluation:
    the paper's GNSS fix at the entrance); 'unknown' = the INS frame is the building frame"""
    imu_yaw_offset: ImuYawOffset = param(ImuYawOffset())
    """walking direction minus the INS heading"""
    step_noise: StepNoise = param(StepNoise())
    """least per-step noise in the covariance"""
    drift: Drift = param(Drift())
    """heading-rate and step-scale error states; the contradiction gate of corrections"""
    integrity: IntegrityParams = param(IntegrityParams())
    """protection radius containment and the alert limit of 'trusted'"""
    max_bridge_speed: float = param(3.0, unit="m/s", gt=0)
    """a gap in the odometry is bridged from the INS's absolute positions only if the implied speed
    is below this"""
