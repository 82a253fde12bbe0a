"""Parameters of the particle filter, in groups: start, time update (motion), resampling,
particles injected by constraints and the map-error monitor. Defaults are the paper's
(search-pattern paper §V-B) where it gives them."""
from __future__ import annotations

import math
from typing import Annotated, Literal

from pydantic import BeforeValidator

from firenav_framework import Angle, AngularRate, Params, StartPose, param
from firenav_framework.contract.params import parse_angle
from firenav_framework.integrity import IntegrityParams

from ..start_pose import start_pose_type
from .motion import MotionNoise
from .resampling import Resampler

DEG = math.pi / 180.0

#: A heading noise per metre walked [rad/m]; YAML may say ``2 deg/m``.
AnglePerMetre = Annotated[float, BeforeValidator(
    lambda v: parse_angle(v, {"": 1.0, "rad/m": 1.0, "deg/m": DEG}))]


class ParticleFilterStart(StartPose):
    """:class:`StartPose` with the spread of a start at the entrance: particles uniform over
    the free space near it (the entrance lies on the outer wall, so a Gaussian would put
    half of them outside). Mode ``unknown`` is the global initialisation of §V-C: uniform
    over the free space of every floor, all headings."""

    entrance_radius: float = param(1.5, unit="m", gt=0)
    """mode 'entrance': particles within this radius of the entrance (instead of a Gaussian of
    sigma_position)"""


DEFAULT_START = ParticleFilterStart(mode="unknown", sigma_position=0.1, sigma_heading=5 * DEG)
#: A start pose without a heading gives particles of all headings.
Start = start_pose_type(DEFAULT_START, modes=("unknown", "pose", "entrance", "truth"),
                        needs_heading=False)


class Motion(Params):
    """The time update: the odometry increment plus noise, per particle."""

    position_noise: float = param(0.12, unit="m", ge=0)
    """position noise per axis per noise_period (§V-B)"""
    noise_period: float = param(0.5, unit="s", gt=0)
    """update period the noise figures refer to (2 Hz in §V-B)"""
    heading_noise: AnglePerMetre = param(2 * DEG, unit="rad/m", ge=0)
    """heading noise per metre walked (§V-B)"""
    noise_while_still: bool = param(True)
    """add the noise also over odometry increments labelled 'still' (the paper adds it at every 2
    Hz update); false: a foot at rest, where a ZUPT INS does not drift, does not spread the
    particles"""
    crawl_position_noise: float | None = param(None, unit="m", ge=0)
    """position noise over odometry labelled 'crawl' (the foot INS is far less sure of a crawl;
    default: position_noise)"""
    crawl_heading_noise: AnglePerMetre | None = param(None, unit="rad/m", ge=0)
    """heading noise per metre crawled (default: heading_noise)"""
    step_scale_sigma: float = param(0.0, ge=0, lt=0.5)
    """spread of a per-particle step-length scale around 1 (0 disables the scale state)"""
    yaw_rate_sigma: AngularRate = param(0.0, unit="rad/s", ge=0)
    """spread of a per-particle drift rate of the INS heading, for odometry whose yaw gyro bias was
    not calibrated (e.g. an IMU's turn-on bias; 0 disables)"""

    def noise(self, crawl: bool = False) -> MotionNoise:
        """The time-update noise for walking (or for odometry labelled 'crawl')."""
        pos, hdg = self.position_noise, self.heading_noise
        if crawl:
            pos = pos if self.crawl_position_noise is None else self.crawl_position_noise
            hdg = hdg if self.crawl_heading_noise is None else self.crawl_heading_noise
        return MotionNoise(position_sigma_m=pos, period_s=self.noise_period,
                           heading_sigma_rad_per_m=hdg)


class Resampling(Params):
    """Replacing improbable particles and resampling the cloud."""

    weight_floor: float = param(0.01, ge=0, lt=1)
    """particles with weight below weight_floor/N are replaced (epsilon = 0.01/N_p, §V-B)"""
    scheme: Resampler = param("systematic")
    """resampling scheme"""
    below_ess: float = param(0.5, ge=0, le=1)
    """resample when ESS < this * N (1 = every update, 0 = never)"""


class Injection(Params):
    """The weight of particles a constraint injects (pseudo-observation resampling)."""

    weight: Literal["neighbours", "uniform"] = param("neighbours")
    """the kernel-weighted mean weight of the particles already near them (neighbours), or 1/N each
    (uniform)"""
    kernel_position: float = param(1.0, unit="m", gt=0)
    """neighbours: kernel width per axis"""
    kernel_heading: Angle = param(30 * DEG, unit="rad", gt=0)
    """neighbours: kernel width on heading"""


class MapError(Params):
    """The spread monitor of §V-E."""

    variance: float = param(3.0, unit="m^2", gt=0)
    """var_x + var_y above which the estimate is not trusted / a map error is suspected"""
    clear: float | None = param(None, unit="m^2", gt=0)
    """var_x + var_y below which a map error clears (default: the same threshold)"""


class Trust(Params):
    """The protection radius of the cloud and the contradiction monitor (:mod:`.trust`)."""

    kernel: float = param(0.5, unit="m", ge=0)
    """each particle blurred by a Gaussian of this sigma per axis in the protection radius and the
    published covariance"""
    spread_scale: float = param(1.0, ge=1)
    """the cloud's horizontal spread is taken this many times wider in the protection radius and
    the published covariance (a cloud under a plan that is partly wrong is narrower than its
    error)"""
    retained_floor: float = param(0.25, ge=0, lt=1)
    """smoothed share of the prior weight the constraints keep below which the motion contradicts
    the plan (0 disables)"""
    smoothing: float = param(0.3, gt=0, le=1)
    """weight of the newest update in the smoothed retained share"""
    hold: float = param(10.0, unit="s", ge=0)
    """the pose stays untrusted this long after the last contradiction"""
    widen_position: float = param(0.3, unit="m", ge=0)
    """position jitter per axis added to the cloud at every contradicted update"""
    widen_heading: Angle = param(3 * DEG, unit="rad", ge=0)
    """frame-rotation jitter added at every contradicted update"""
    jump: float | None = param(None, unit="m", gt=0)
    """a reweighting shift of the mean (summed over jump_window) longer than this is a jump between
    hypotheses: reported, and the pose untrusted until jump_evidence metres are walked (None
    disables)"""
    jump_window: float = param(5.0, unit="s", gt=0)
    """window over which reweighting shifts are summed"""
    jump_evidence: float = param(10.0, unit="m", ge=0)
    """distance to walk after a jump before the pose may be trusted again"""
    plan_evidence: float | None = param(None, gt=0, lt=1)
    """product of the retained shares of the prior weight over the last plan_window metres below
    which the motion contradicts the plan: untrusted, map_error (None disables)"""
    plan_window: float = param(10.0, unit="m", gt=0)
    """distance walked over which plan_evidence multiplies the retained shares"""
    refuted_evidence: float = param(0.0, unit="m", ge=0)
    """after the plan contradicted the cloud (either monitor), the pose stays untrusted until this
    distance is walked without another contradiction (0 disables)"""
    untrusted_growth: float = param(0.0, ge=0)
    """while the pose is not trusted, a horizontal sigma of this much per metre walked since it
    last was [m/m] is added per axis to the published covariance (0 disables)"""


class Stairs(Params):
    """Where particles change floor (:mod:`.stairs`)."""

    margin: float = param(1.0, unit="m", ge=0, le=5)
    """how far outside a stair's footprint a particle still accumulates the odometry's climb and
    may change floor (0: on the footprint only)"""
    height_factor: float = param(1.0, gt=0, le=1)
    """at every update, the weight of a particle whose height (its floor's level plus its climb)
    is more than height_tolerance off the INS's height (from the start's) is multiplied by this,
    and a pose whose height is that far off is not trusted (1 disables both, as do a building of one floor and the unknown start; :mod:`.height`)"""
    height_tolerance: float = param(1.0, unit="m", gt=0)
    """how far a particle's height may be off the INS's before it counts as on another floor"""


class ParticleFilterParams(Params):
    particles: int = param(500, gt=0, le=100_000)
    """particles per firefighter (N_p, §V-B)"""
    start: Start = param(DEFAULT_START)
    """the initial cloud: mode 'unknown' = spread over the free space, all headings (§V-C); 'pose'
    = around the start pose (all headings without one); 'entrance' = near a building entrance,
    heading inwards; 'truth' = around the agent's first ground-truth pose (evaluation of the
    known-start case only)"""
    motion: Motion = param(Motion())
    """time update"""
    resampling: Resampling = param(Resampling())
    """replacement and resampling"""
    injection: Injection = param(Injection())
    """particles injected by constraints"""
    map_error: MapError = param(MapError())
    """map-error monitor (§V-E)"""
    integrity: IntegrityParams = param(IntegrityParams())
    """when a pose is trusted"""
    stairs: Stairs = param(Stairs())
    """floor changes on stairs"""
    trust: Trust = param(Trust())
    """protection radius and contradiction monitor"""
    update_interval: float = param(0.5, unit="s", ge=0)
    """odometry is summed to at least this interval per update (2 Hz in §V-B)"""
    offset_window: float = param(20.0, unit="m", gt=0)
    """path length over which the IMU-yaw to walking-direction offset is estimated (footnote 4)"""
    seed: int = param(0)
    """random seed (combined with the agent name)"""
