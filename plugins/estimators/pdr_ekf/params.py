"""Parameters of the RFID/MEMS PDR EKF (one pydantic model: YAML schema, docs, defaults).

Paper values where the paper gives them (rfid-mems-ekf): synchronous update every second
("System model"), 20 cm per counted stair ("MEMS Navigation Module"), tags on door jambs
and stair ends. Every noise level below is ours (the paper gives none): they describe
the foot-INS odometry this filter is fed with and the geometry of a door passage.
"""
from __future__ import annotations

import math
from typing import Literal

from pydantic import model_validator

from firenav_framework import Params, param

from .door_heading import DoorHeadingConfig
from .flight_tracker import FlightConfig
from .gait import GaitConfig

DEG = math.pi / 180.0


class PdrEkfParams(Params):
    # -- timing ------------------------------------------------------------------------
    update_period: float | None = param(1.0, unit="s", gt=0, description="synchronous "
                                        "update period (the paper: every second); null = "
                                        "update at every odometry stride")
    # -- alignment of the odometry frame -------------------------------------------------
    alignment: Literal["entrance", "pose", "none"] = param(
        "entrance", description="how the odometry frame is placed in the building: "
        "'entrance' = start at the building entrance, the foot pointing inward when the "
        "walk begins; 'pose' = start_position/start_heading when the walk begins; 'none' "
        "= the odometry is already in the building frame (dead_reckoning output, e.g. "
        "ORCA-corrected)")
    entrance: str | None = param(None, description="entrance id (default: the first one)")
    start_position: tuple[float, float, float] | None = param(
        None, unit="m", description="'pose': start position (x, y, z), building frame")
    start_heading: float | None = param(None, unit="rad", description="'pose': heading of "
                                        "the foot at the start, building frame")
    entrance_heading_update: bool = param(True, description="'entrance': the first strides "
                                          "through the entrance door give a heading update "
                                          "(eq. 3, no ambiguity: the agent walks in)")
    start_sigma: float = param(0.5, unit="m", gt=0, description="start position uncertainty "
                               "(1 sigma per horizontal axis)")
    start_sigma_heading: float = param(10 * DEG, unit="rad", gt=0, description="start heading "
                                       "uncertainty (foot mounting yaw, alignment)")
    # -- process noise (eq. 2) -----------------------------------------------------------
    start_sigma_scale: float = param(0.05, gt=0, description="initial uncertainty of the "
                                     "step-length scale factor lambda")
    stride_noise: float = param(0.05, unit="m", ge=0, description="extra horizontal noise "
                                "per stride, on top of the odometry's own covariance")
    scale_rw: float = param(0.002, unit="1/sqrt(s)", ge=0, description="random walk of lambda")
    heading_rw: float = param(0.5 * DEG, unit="rad/sqrt(s)", ge=0, description="random walk "
                              "of the heading perturbation dtheta (residual gyro bias)")
    heading_turn_noise: float = param(0.1, ge=0, description="dtheta noise per radian "
                                      "turned (1 sigma): a foot INS's heading error grows "
                                      "in turns and on stairs far beyond the gyro scale "
                                      "factor")
    # -- height, gait, floors --------------------------------------------------------------
    height_source: Literal["stairs", "ins"] = param(
        "stairs", description="Z from counted stairs (the paper) or from the INS height "
        "change (cleared of its drift gradient)")
    step_height: float = param(0.20, unit="m", gt=0, description="nominal stair rise (the "
                               "paper: 20 cm)")
    step_height_from_building: bool = param(True, description="use the rise of the building's "
                                            "stair when the agent is on one")
    stair_zone: float | None = param(3.0, unit="m", gt=0, description="the building's "
                                     "flights are followed: a stair stride counts only "
                                     "this close to (beyond half the width of) a flight's "
                                     "walking line, going along it from the end at the "
                                     "current level, and the height is set to the level "
                                     "a flight ends on once it is completed or left "
                                     "(null: the paper's free stair counting anywhere, "
                                     "no map)")
    flight_complete: float = param(0.5, gt=0, le=1, description="a flight is completed "
                                   "when at least this share of its stairs were counted "
                                   "when the agent leaves it (else the agent went back)")
    stair_sigma: float = param(0.02, unit="m", ge=0, description="height noise per counted stair")
    floor_snap: float = param(0.5, unit="m", ge=0, description="without the flights "
                              "(stair_zone null or height_source 'ins'): at the end of a "
                              "run of stair strides, a height this close to a floor level "
                              "or a landing is set to it (0: off)")
    max_stairs_per_stride: int = param(2, ge=1, description="most stairs counted in one "
                                       "stride of the instrumented foot (two steps)")
    gait_source: Literal["stride", "odometry"] = param(
        "stride", description="gait classes from our stride classifier ('stride') or the "
        "odometry's own motion labels")
    stair_min_rise: float = param(0.5, gt=0, description="a stair stride rises at least this "
                                  "many stairs")
    stair_slope: float = param(0.2, gt=0, description="a stair stride's rise over its "
                               "horizontal length is at least this")
    # -- RFID ----------------------------------------------------------------------------
    rfid: bool = param(True, description="use tags (false: MEMS alone, the paper's baseline)")
    tag_sigma: float = param(0.5, unit="m", gt=0, description="horizontal distance of the "
                             "reader from the tag's site at the strongest read (1 sigma)")
    tag_sigma_z: float = param(0.1, unit="m", gt=0, description="height of the agent at a tag "
                               "site vs. its floor level (1 sigma)")
    tag_level_gate: float | None = param(1.0, unit="m", gt=0, description="a tag read "
                                         "farther than this from the estimated height "
                                         "sets the height to the tag's floor level (a "
                                         "flight was missed); null: only the Gaussian "
                                         "update with tag_sigma_z")
    tag_gate: float | None = param(5.0, gt=0, description="horizontal Mahalanobis distance "
                                   "beyond which a tag detection means the filter has lost "
                                   "track (null: never)")
    on_gate: Literal["relocate", "reject"] = param(
        "relocate", description="a detection beyond tag_gate: 'relocate' = trust the tag "
        "(a read is within a metre or two of it), widening the covariance first; 'reject' "
        "= refuse it (if tag ids may be duplicated)")
    relocate_heading_sigma: float = param(20 * DEG, unit="rad", gt=0, description="heading "
                                          "perturbation uncertainty added on a relocation")
    correct_on_deploy: bool = param(True, description="the deploying agent's position is "
                                    "corrected to the site its new tag was associated with")
    associate_gate: float | None = param(None, gt=0, description="a new tag is associated "
                                         "only with a site within this many sigma (null: "
                                         "always the least-cost free site)")
    repeat_holdoff: float = param(15.0, unit="s", ge=0, description="a detection of the tag "
                                  "this agent last used, within this time, is not used again")
    max_wait: float = param(2.0, unit="s", gt=0, description="a tag event waits at most this "
                            "long for the odometry to catch up with its time")
    surveyed_tags: dict[str, str] = param({}, description="tags known before the run: tag id "
                                          "-> tag site id (door id, or '<stair>/bottom|top')")
    heading_sites: list[Literal["door", "stair"]] = param(
        ["door", "stair"], description="tag sites whose crossing direction updates the heading")
    # -- door heading (eq. 3) ---------------------------------------------------------------
    door_heading: bool = param(True, description="door-crossing heading updates (eq. 3)")
    door_strides: int = param(3, ge=1, description="n_s: strides averaged after the door")
    door_clear_distance: float = param(1.0, unit="m", ge=0, description="distance walked past "
                                       "the tag before the averaging starts")
    door_sigma: float = param(5 * DEG, unit="rad", gt=0, description="walking direction vs. "
                              "door axis (1 sigma) for a straight crossing")
    door_discrepancy_scale: float = param(15 * DEG, unit="rad", gt=0, description="d0 of the "
                                          "adaptive variance (sigma^2 exp((d/d0)^2))")
    door_max_discrepancy: float = param(45 * DEG, unit="rad", gt=0, description="a larger "
                                        "discrepancy refuses the heading update")

    @model_validator(mode="after")
    def _pose(self) -> "PdrEkfParams":
        if self.alignment == "pose" and (self.start_position is None or self.start_heading is None):
            raise ValueError("alignment 'pose' needs start_position and start_heading")
        return self

    def gait_config(self) -> GaitConfig:
        return GaitConfig(step_height=self.step_height, min_rise=self.stair_min_rise,
                          stair_slope=self.stair_slope)

    def flight_config(self) -> FlightConfig:
        return FlightConfig(complete_fraction=self.flight_complete,
                            max_per_stride=self.max_stairs_per_stride,
                            step_height=None if self.step_height_from_building
                            else self.step_height)

    def door_config(self) -> DoorHeadingConfig:
        return DoorHeadingConfig(strides=self.door_strides, clear_distance=self.door_clear_distance,
                                 sigma=self.door_sigma,
                                 discrepancy_scale=self.door_discrepancy_scale,
                                 max_discrepancy=self.door_max_discrepancy)
