"""Parameters of the RFID/MEMS PDR EKF, in groups: start, process noise (eq. 2), height
and floors, gait classes, RFID tags and the door-crossing heading (eq. 3).

Paper values where the paper gives them (rfid-mems-ekf): synchronous update every second
("System model"), 20 cm per counted stair ("MEMS Navigation Module"), tags on door jambs
and stair ends. Every noise level below is ours (the paper gives none): they describe
the foot-INS odometry this filter is fed with and the geometry of a door passage.
"""
from __future__ import annotations

import math
from typing import Literal

from firenav_framework import Angle, AngularRate, Params, StartPose, param
from firenav_framework.integrity import IntegrityParams

from ..start_pose import start_pose_type
from .baro_floor import BaroConfig
from .door_heading import DoorHeadingConfig
from .flight_tracker import FlightConfig
from .gait import GaitConfig

DEG = math.pi / 180.0


class Process(Params):
    """Process noise of eq. 2 and the initial step-scale uncertainty."""

    scale_sigma: float = param(0.05, gt=0)
    """initial uncertainty of the step-length scale factor lambda"""
    stride_noise: float = param(0.05, unit="m", ge=0)
    """extra horizontal noise per stride, on top of the odometry's own covariance"""
    scale_rw: float = param(0.002, unit="1/sqrt(s)", ge=0)
    """random walk of lambda"""
    heading_rw: float = param(0.5 * DEG, unit="rad/sqrt(s)", ge=0)
    """random walk of the heading perturbation dtheta (residual gyro bias)"""
    heading_turn_noise: float = param(0.1, unit="rad/rad", ge=0)
    """dtheta noise per radian turned (1 sigma): a foot INS's heading error grows in turns and on
    stairs far beyond the gyro scale factor"""
    heading_rate_sigma: AngularRate = param(0.2 * DEG, unit="rad/s", ge=0)
    """initial uncertainty of the heading perturbation's rate omega (the vertical gyro bias the INS
    leaves in; 0: the paper's five-state filter)"""
    heading_rate_rw: float = param(0.0, unit="rad/s/sqrt(s)", ge=0)
    """random walk of omega (gyro bias instability)"""


class Height(Params):
    """Height from stairs (or the INS) and the floor levels."""

    source: Literal["stairs", "ins"] = param("stairs")
    """Z from counted stairs (the paper) or from the INS height change (cleared of its drift
    gradient)"""
    step_height: float = param(0.20, unit="m", gt=0)
    """nominal stair rise (the paper: 20 cm)"""
    step_height_from_building: bool = param(True)
    """use the rise of the building's stair when the agent is on one"""
    stair_zone: float | None = param(3.0, unit="m", gt=0)
    """the building's flights are followed: a stair stride counts only this close to (beyond half
    the width of) a flight's walking line, going along it from the end at the current level, and
    the height is set to the level a flight ends on once it is completed or left (null: the
    paper's free stair counting anywhere, no map)"""
    flight_complete: float = param(0.5, gt=0, le=1)
    """a flight is completed when at least this share of its stairs were counted when the agent
    leaves it (else the agent went back)"""
    stair_sigma: float = param(0.02, unit="m", ge=0)
    """height noise per counted stair"""
    floor_snap: float = param(0.5, unit="m", ge=0)
    """without the flights (stair_zone null or source 'ins'): at the end of a run of stair strides,
    a height this close to a floor level or a landing is set to it (0: off)"""
    max_stairs_per_stride: int = param(2, ge=1)
    """most stairs counted in one stride of the instrumented foot (two steps)"""

    def flight_config(self) -> FlightConfig:
        return FlightConfig(complete_fraction=self.flight_complete,
                            max_per_stride=self.max_stairs_per_stride,
                            step_height=None if self.step_height_from_building
                            else self.step_height)


class Gait(Params):
    """The stride classes (FW, SC, SDF, SDB, still)."""

    source: Literal["stride", "odometry"] = param("stride")
    """gait classes from our stride classifier ('stride') or the odometry's own motion labels"""
    stair_min_rise: float = param(0.5, gt=0)
    """a stair stride rises at least this many stairs"""
    stair_slope: float = param(0.2, gt=0)
    """a stair stride's rise over its horizontal length is at least this"""


class Rfid(Params):
    """Tags deployed on door jambs and stair ends, and their reads."""

    enabled: bool = param(True)
    """use tags (false: MEMS alone, the paper's baseline)"""
    sigma: float = param(0.8, unit="m", gt=0)
    """horizontal distance of the reader from the tag's site at the strongest read (1 sigma), with
    the plan's error of the door's place"""
    sigma_z: float = param(0.1, unit="m", gt=0)
    """height of the agent at a tag site vs. its floor level (1 sigma)"""
    level_gate: float | None = param(1.0, unit="m", gt=0)
    """a tag read farther than this from the estimated height sets the height to the tag's floor
    level (a flight was missed); null: only the Gaussian update with sigma_z"""
    gate: float | None = param(5.0, gt=0)
    """horizontal Mahalanobis distance beyond which a tag detection means the filter has lost track
    (null: never)"""
    on_gate: Literal["relocate", "reject"] = param("relocate")
    """a detection beyond gate: 'relocate' = trust the tag (a read is within a metre or two of it),
    widening the covariance first; 'reject' = refuse it (if tag ids may be duplicated)"""
    relocate_heading_sigma: Angle = param(20 * DEG, unit="rad", gt=0)
    """heading perturbation uncertainty added on a relocation"""
    relocate_scale: bool = param(True)
    """a relocation also returns the step-length scale lambda to its prior (1, process.scale_sigma):
    what the drifted track's tag updates taught it is suspect (false: lambda keeps its estimate)"""
    correct_on_deploy: bool = param(True)
    """the deploying agent's position is corrected to the site its new tag was associated with"""
    associate_gate: float | None = param(None, gt=0)
    """a new tag is associated only with a site within this many sigma (null: always the least-cost
    free site)"""
    associate_confidence: float = param(0.9, gt=0, le=1)
    """a new tag whose most probable site has less probability is tentative: corrected to that site
    with a noise covering the other candidates, and weighed again at every read until one site
    has this probability (a tiny value: the paper's least-cost association, always resolved)"""
    repeat_holdoff: float = param(15.0, unit="s", ge=0)
    """a detection of the tag this agent last used, within this time, is not used again"""
    max_wait: float = param(2.0, unit="s", gt=0)
    """a tag event waits at most this long for the odometry to catch up with its time"""
    surveyed: dict[str, str] = param({})
    """tags known before the run: tag id -> tag site id (door id, or '<stair>/bottom|top')"""


class DoorHeading(Params):
    """The door-crossing heading update of eq. 3."""

    enabled: bool = param(True)
    """door-crossing heading updates"""
    at_entrance: bool = param(True)
    """start mode 'entrance': the first strides through the entrance door give a heading update (no
    ambiguity: the agent walks in)"""
    sites: list[Literal["door", "stair"]] = param(["door", "stair"])
    """tag sites whose crossing direction updates the heading"""
    strides: int = param(3, ge=1)
    """n_s: strides averaged after the door"""
    clear_distance: float = param(1.0, unit="m", ge=0)
    """distance walked past the tag before the averaging starts"""
    sigma: Angle = param(5 * DEG, unit="rad", gt=0)
    """walking direction vs. door axis (1 sigma) for a straight crossing"""
    discrepancy_scale: Angle = param(15 * DEG, unit="rad", gt=0)
    """d0 of the adaptive variance (sigma^2 exp((d/d0)^2))"""
    max_discrepancy: Angle = param(45 * DEG, unit="rad", gt=0)
    """a larger discrepancy refuses the heading update"""

    def config(self) -> DoorHeadingConfig:
        return DoorHeadingConfig(strides=self.strides, clear_distance=self.clear_distance,
                                 sigma=self.sigma, discrepancy_scale=self.discrepancy_scale,
                                 max_discrepancy=self.max_discrepancy)


class Barometer(Params):
    """The height from a barometer's PressureHeight, where one is fitted (baro_floor.py)."""

    enabled: bool = param(True)
    """use PressureHeight messages when they arrive"""
    gate: float = param(1.2, unit="m", gt=0)
    """the offset is learnt on a level only when the barometer (offset removed) is this near a
    floor's level (a storey is 3-3.5 m)"""
    window: float = param(4.0, unit="s", gt=0)
    """span of barometer heights that tells walking on a level"""
    still_range: float = param(0.5, unit="m", gt=0)
    """on a level: the heights of the window span less than this"""
    offset_sigma: float = param(1.0, unit="m", gt=0)
    """initial 1-sigma of the barometer's offset (zeroing, indoor pressure)"""
    offset_rw: float = param(0.01, unit="m/sqrt(s)", ge=0)
    """random walk of the offset (doors, fire, ventilation)"""
    noise: float = param(0.15, unit="m", gt=0)
    """short-term noise of one report"""

    def config(self) -> BaroConfig:
        return BaroConfig(gate=self.gate, window=self.window, still_range=self.still_range,
                          offset_sigma=self.offset_sigma, offset_rw=self.offset_rw,
                          noise=self.noise)


#: The start is placed when the walk begins: at the entrance by default, the foot pointing
#: inward, 0.5 m and 10 deg uncertain (foot mounting yaw, alignment).
DEFAULT_START = StartPose(mode="entrance", sigma_position=0.5, sigma_heading=10 * DEG)
PdrEkfStart = start_pose_type(DEFAULT_START, modes=("entrance", "pose", "unknown"))


class PdrEkfParams(Params):
    update_period: float | None = param(1.0, unit="s", gt=0)
    """synchronous update period (the paper: every second); null = update at every odometry stride"""
    start: PdrEkfStart = param(DEFAULT_START)
    """where the odometry frame is placed when the walk begins: mode 'entrance' = the building
    entrance, the foot pointing inward; 'pose' = start position and the heading of the foot;
    'unknown' = the odometry is in the building frame already (dead_reckoning output, e.g. ORCA-
    corrected)"""
    process: Process = param(Process())
    """process noise (eq. 2)"""
    height: Height = param(Height())
    """height and floors"""
    gait: Gait = param(Gait())
    """stride classes"""
    rfid: Rfid = param(Rfid())
    """RFID tags"""
    door_heading: DoorHeading = param(DoorHeading())
    """door-crossing heading (eq. 3)"""
    barometer: Barometer = param(Barometer())
    """floor from a barometer"""
    integrity: IntegrityParams = param(IntegrityParams())
    """when a pose is trusted (protection radius within the alert limit, no contradicting tag read
    pending)"""

    def gait_config(self) -> GaitConfig:
        return GaitConfig(step_height=self.height.step_height, min_rise=self.gait.stair_min_rise,
                          stair_slope=self.gait.stair_slope)
