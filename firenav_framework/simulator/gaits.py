"""Ways of moving (gaits) and the people who move (person variation).

Defaults come from gait literature, the reference papers and the real recordings in
``../shared/data``: normal walking at 1.3 m/s with a 1.4 m stride, heel-off to foot-flat
1.07 s at most (the moving phase stays about a second long whatever the pace, the flat
still stance takes up the rest of the stride, at least ``min_flat_s``), of which the
foot rolls over its ball for 0.37 s (terminal stance and pre-swing) and down about its
heel for 0.16 s (loading response); the boot flexes over a contact more the faster one
walks (``flex_scale``). Timing, quiet time per stride, impacts and flex were checked per
pace against the real VICON trials and the indoor walks (``benchmarks/bench_sim_realism.py``,
docs/scenarios.md); running (3 m/s, no still moment) against the real running trials,
crawling on hands and knees (the shoe on its top) against the real crawl trials.
Careful walking in smoke at 0.3-0.8 m/s (the issue; the breadcrumb paper's "trail
step", Sec. V-C); searching at about 0.5 m/s; knee-walking on tucked toes; stairs one
step per foot (a stride spans two treads), descended forwards or backwards
(search-pattern paper Sec. II; RFID paper, gait classes FW/SC/SDF/SDB). A scenario may
override any field per gait name or add gaits of its own.
"""
from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import ConfigDict, Field

from ..field_docs import DescribedModel

Posture = Literal["stand", "kneel", "crawl"]


class Gait(DescribedModel):
    """The foot motion of one way of moving (per stride of the instrumented foot)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    speed: float = Field(1.3, gt=0, le=4.0)
    """walking speed along the path [m/s]"""
    stride: float = Field(1.4, gt=0.05, le=2.5)
    """stride length of one foot at this speed [m]"""
    swing_s: float = Field(1.07, gt=0.2, le=3.0)
    """heel-off to foot-flat [s] (at most: a stride keeps min_flat_s flat); the rest of the stride
    the foot is flat and still (0.1 s at 1.3 m/s, 0.2 s at 0.9 m/s)"""
    toe_rocker_s: float = Field(0.37, ge=0, le=1.2)
    """heel-off to toe-off [s]: the foot rolls over the ball (terminal stance and pre-swing, 20-30
    % of the gait cycle)"""
    heel_rocker_s: float = Field(0.16, ge=0, le=0.6)
    """heel strike to foot-flat [s]: the foot rolls down about the heel (loading response, about 10
    % of the gait cycle)"""
    clearance: float = Field(0.06, ge=0, le=0.5)
    """lift of the foot's contact point (ball, then heel) at mid-swing [m]; the IMU rises more as
    the foot pitches"""
    toe_off_deg: float = Field(55.0, ge=-60, le=80)
    """toe-down pitch at toe-off (the largest plantarflexion after it; crawling: the turn of the
    lifted shoe)"""
    heel_strike_deg: float = Field(20.0, ge=0, le=45)
    """toe-up pitch at heel strike"""
    roll_deg: float = Field(4.0, ge=0, le=20)
    """foot inversion at toe-off and at heel strike"""
    sway: float = Field(0.02, ge=0, le=0.2)
    """lateral foot excursion in swing [m]"""
    impact_mm: float = Field(2.5, ge=0, le=20)
    """heel pad / sole give at heel strike, down and forward (peaks of 3-4 g at normal walking, as
    on the real recordings) [mm]"""
    free_turn_deg: float = Field(0.0, ge=0.0, le=90.0)
    """a curve of up to this much per stride is walked at full pace (beyond it, and always on the
    spot, turning costs time: 60 degrees a stride) [deg]"""
    flex_scale: float = Field(1.0, ge=0.0, le=5.0)
    """how far the boot flexes over a ground contact, relative to walking (the mount's flex_deg;
    running pushes harder)"""
    min_flat_s: float = Field(0.1, ge=0.0, le=1.0)
    """shortest flat stance of a stride [s] (running: the foot is flat for an instant only)"""
    posture: Posture = Field("stand")
    """stand; kneel (on the knees, toes tucked under: knee-walking); crawl (on hands and knees, the
    shoe on its top behind the knee)"""


#: Built-in gaits. ``stairs_*`` strides span two treads; their speed is unused.
GAITS: dict[str, Gait] = {
    "walk": Gait(),
    "brisk": Gait(speed=1.6, stride=1.6, swing_s=1.02, toe_rocker_s=0.36, heel_rocker_s=0.13,
                  clearance=0.07, toe_off_deg=60, impact_mm=3.5, flex_scale=1.6),
    "slow": Gait(speed=0.5, stride=0.85, swing_s=1.0, toe_rocker_s=0.40, heel_rocker_s=0.15,
                 clearance=0.05, toe_off_deg=30, heel_strike_deg=12, impact_mm=1.5,
                 flex_scale=0.6),
    "search": Gait(speed=0.5, stride=0.8, swing_s=1.0, toe_rocker_s=0.40, heel_rocker_s=0.15,
                   clearance=0.05, toe_off_deg=25, heel_strike_deg=10, impact_mm=1.5,
                   flex_scale=0.6),
    "trail_step": Gait(speed=0.3, stride=0.6, swing_s=1.1, toe_rocker_s=0.45,
                       heel_rocker_s=0.15, clearance=0.04, toe_off_deg=15, heel_strike_deg=8,
                       sway=0.01, impact_mm=1.0),
    "knee_walk": Gait(speed=0.2, stride=0.35, swing_s=1.0, toe_rocker_s=0.0, heel_rocker_s=0.0,
                      clearance=0.03, toe_off_deg=5, heel_strike_deg=0, roll_deg=2, sway=0.01,
                      impact_mm=0.0, posture="kneel"),
    # hands and knees, the shoe lying on its top behind the knee: it is lifted a few
    # centimetres, turned and set down again, about 0.55 m per 1.4 s (the real crawl
    # trials of ../shared/data: 0.33-0.48 m/s, strides of 1.25-1.45 s, quiet below
    # 20 deg/s for 0.26-0.43 s of each)
    "crawl": Gait(speed=0.4, stride=0.55, swing_s=1.05, toe_rocker_s=0.0, heel_rocker_s=0.0,
                  clearance=0.05, toe_off_deg=25, heel_strike_deg=0, roll_deg=5, sway=0.02,
                  impact_mm=2.5, min_flat_s=0.25, posture="crawl"),
    # running in a corridor at 3 m/s: 2.2 m strides every 0.73 s, about 0.25 s on the
    # ground with a short heel-to-forefoot roll and no still moment, the boot flexing
    # hard (the real running trials of ../shared/data at 1.3-2 m/s: quiet below 20 deg/s
    # for 0-0.04 s per stride, the rate never under 15-29 deg/s, landings of 5-8 g)
    "run": Gait(speed=3.0, stride=2.2, swing_s=0.62, toe_rocker_s=0.10, heel_rocker_s=0.04,
                clearance=0.15, toe_off_deg=70, heel_strike_deg=5, roll_deg=10, sway=0.02,
                impact_mm=2.5, flex_scale=1.8, min_flat_s=0.05),
    "stairs_up": Gait(speed=0.5, stride=0.6, swing_s=0.75, toe_rocker_s=0.20,
                      heel_rocker_s=0.05, clearance=0.06, toe_off_deg=25, heel_strike_deg=5,
                      impact_mm=3.0),
    "stairs_down": Gait(speed=0.5, stride=0.6, swing_s=0.70, toe_rocker_s=0.15,
                        heel_rocker_s=0.05, clearance=0.04, toe_off_deg=10, heel_strike_deg=5,
                        impact_mm=6.0),
    "stairs_down_backward": Gait(speed=0.3, stride=0.6, swing_s=0.9, toe_rocker_s=0.15,
                                 heel_rocker_s=0.0, clearance=0.04, toe_off_deg=20,
                                 heel_strike_deg=0, impact_mm=2.0),
}

#: Direction in which the boot's upper under the IMU turns relative to the sole over a
#: ground contact (rotation vector per unit angle, foot frame: roll, pitch, yaw) for a
#: *right* foot; the left foot mirrors roll and yaw. Measured in mid-stance on the real
#: indoor walks (benchmarks/bench_sim_realism.py): eversion, the shank rolling forward
#: (toe-down sign), outward rotation, at about 4 : 8 : 5.
FLEX_DIRECTION_RIGHT = np.array([-0.41, 0.76, -0.51]) / np.linalg.norm([-0.41, 0.76, -0.51])
#: The same on all fours: the shoe lying on its top rocks as the body's weight shifts
#: over the knees, mostly about its long axis (assumed).
CRAWL_FLEX_DIRECTION_RIGHT = np.array([0.89, 0.45, 0.0])

#: Stance duration per stride on stairs [s] (foot flat on a tread).
STAIR_STANCE_S = {"stairs_up": 0.45, "stairs_down": 0.40, "stairs_down_backward": 0.8}

#: Foot pitch at rest per posture [rad] (positive: toe down): standing flat; kneeling
#: and knee-walking on tucked toes (sole near vertical); crawling on hands and knees with
#: the shoe upside down on its top, toes pointing back (the real crawl trials at rest:
#: the IMU within 10 degrees of upside down). And the IMU's height above the floor [m]
#: when not standing (standing: the person's ``imu_height``).
POSTURE_PITCH = {"stand": 0.0, "kneel": np.radians(70.0), "crawl": np.radians(-175.0)}
POSTURE_IMU_HEIGHT = {"kneel": 0.11, "crawl": 0.10}
#: The gait of small moves (turning on the spot) per posture.
POSTURE_GAIT = {"stand": "walk", "kneel": "knee_walk", "crawl": "crawl"}
KNEEL_PITCH = POSTURE_PITCH["kneel"]
#: Duration of getting down to / up from the knees [s].
POSTURE_CHANGE_S = 1.3


class Person(DescribedModel):
    """How one firefighter differs from the nominal gaits.

    Unset scales are drawn per seed: ``stride_scale`` ~ N(1, 0.06) (body height),
    ``speed_scale`` ~ N(1, 0.05) (temperament, load). ``foot`` says which foot wears
    the IMU; the foot lands ``foot_offset`` [m] beside the body's path line and points
    ``toe_out_deg`` outwards. ``jitter`` is the stride-to-stride variation of length and
    duration (fraction, 1 sigma) and ``heading_jitter_deg`` that of foot placement.
    """

    model_config = ConfigDict(extra="forbid", frozen=True)

    stride_scale: float | None = Field(None, gt=0.5, lt=1.5)
    speed_scale: float | None = Field(None, gt=0.5, lt=1.5)
    foot: Literal["right", "left"] = "right"
    foot_offset: float = Field(0.10, ge=0, le=0.3)
    toe_out_deg: float = Field(7.0, ge=-20, le=30)
    imu_height: float = Field(0.06, gt=0, le=0.3)
    """IMU above the floor at stance [m]"""
    imu_from_heel: float = Field(0.10, ge=0, le=0.3)
    """IMU ahead of the heel's contact point [m] (an instep mount)"""
    imu_to_ball: float = Field(0.08, ge=0, le=0.3)
    """ball of the foot (metatarsal heads) ahead of the IMU [m]"""
    jitter: float = Field(0.03, ge=0, le=0.2)
    heading_jitter_deg: float = Field(2.0, ge=0, le=15)

    def drawn(self, rng: np.random.Generator) -> "Person":
        """This person with unset scales drawn (same rng draws whether set or not)."""
        stride, speed = 1.0 + 0.06 * rng.standard_normal(), 1.0 + 0.05 * rng.standard_normal()
        return self.model_copy(update={
            "stride_scale": self.stride_scale or float(np.clip(stride, 0.8, 1.2)),
            "speed_scale": self.speed_scale or float(np.clip(speed, 0.85, 1.15))})
