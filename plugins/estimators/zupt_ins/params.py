"""Parameters of the ZUPT-aided INS, in groups: detector, IMU, filter, ZARU, alignment,
gravity, height, gait labels, odometry noise, outputs and the start pose.

Sensor defaults are MicroStrain 3DM-GX5-25 datasheet values (the IMU of both real
datasets): accelerometer noise density 100 ug/sqrt(Hz), gyro noise density
0.005 deg/s/sqrt(Hz), bias instability 0.04 mg and 8 deg/h. The filter adds a model
error density on top (PyShoe's 0.5 m/s^2 and 0.5 deg/s per 200 Hz sample, as
densities): during a swing the strapdown model errors (vibration, scale factor,
heel-strike shocks, timing) are about 35 times the accelerometer noise. How the
detector defaults were chosen is in ``docs/foot-ins.md``.
"""
from __future__ import annotations

import math
from typing import Literal

from pydantic import model_validator

from firenav_framework import Angle, AngularRate, Params, StartPose, param
from firenav_framework.integrity import IntegrityParams

from ..start_pose import start_pose_type
from . import detectors, eskf
from .pose_uncertainty import FastGaitErrors, PoseUncertainty
from .steps import GaitThresholds, UnmodelledErrors

G_STANDARD = 9.80665
DEG = math.pi / 180.0
UG = 1e-6 * G_STANDARD

#: Fixed-detector thresholds used when ``detector.threshold`` is not given: the best single
#: threshold (grid of quarter decades) over the even-numbered VICON trials.
DEFAULT_THRESHOLDS = {"shoe": 10 ** 8.25, "ared": 10 ** 8.25, "amvd": 10 ** 8.75}


def normal_gravity(latitude: float, height_m: float = 0.0) -> float:
    """WGS-84 normal gravity [m/s^2] (Somigliana) at a geodetic ``latitude`` [rad] with
    the free-air height correction."""
    s2 = math.sin(latitude) ** 2
    g0 = 9.7803253359 * (1 + 0.00193185265241 * s2) / math.sqrt(1 - 0.00669437999013 * s2)
    return g0 - 3.086e-6 * height_m


class CrawlLevels(Params):
    """The adaptive detector's levels while the resting foot lies tilted beyond
    ``gait.crawl_tilt`` (crawling, knee-walking: see ``detectors``)."""

    low: float = param(5.5, unit="log10 T")
    """SHOE statistic below which the foot is surely still"""
    high: float = param(7.2, unit="log10 T")
    """SHOE statistic above which the foot surely moves"""
    kappa: float = param(0.5, gt=0, lt=1)
    """threshold position between stance floor and swing level (log scale)"""
    prominence: float = param(1.0, gt=0, unit="decades")
    """swing level above stance floor needed to call it a gait"""
    min_stance: float = param(0.01, unit="s", ge=0)
    """zero-velocity runs shorter than this are dropped"""
    smoothing: float = param(0.2, unit="s", ge=0)
    """the statistic is averaged over this span, centred (at most twice detector.ahead)"""

    @model_validator(mode="after")
    def _levels(self) -> "CrawlLevels":
        if not self.low <= self.high:
            raise ValueError(f"low ({self.low:g}) must not be above high ({self.high:g})")
        return self


class Detector(Params):
    """Zero-velocity detector."""

    kind: Literal["adaptive", "shoe", "ared", "amvd"] = param("adaptive")
    """adaptive (stance-relative SHOE threshold), or SHOE / ARED / AMVD with a fixed threshold"""
    window: float = param(0.025, unit="s", gt=0)
    """detector window, centred (W = odd number of samples nearest; at least 3)"""
    threshold: float | None = param(None, gt=0)
    """fixed detectors: zero velocity when the statistic T is below this (default per detector)"""
    low: float = param(6.6, unit="log10 T")
    """adaptive: SHOE statistic below which the foot is surely still"""
    high: float = param(9.0, unit="log10 T")
    """adaptive: SHOE statistic above which the foot surely moves"""
    kappa: float = param(0.25, gt=0, lt=1)
    """adaptive: threshold position between stance floor and swing level (log scale)"""
    prominence: float = param(2.0, gt=0, unit="decades")
    """adaptive: swing level above stance floor needed to call it a gait"""
    ahead: float = param(0.3, unit="s", ge=0)
    """adaptive: look-ahead (latency)"""
    swing_back: float = param(1.5, unit="s", gt=0)
    """adaptive: look-back of the swing level"""
    floor_back: float = param(0.7, unit="s", gt=0)
    """adaptive: look-back of the stance floor (shorter than a stride: follows a change of gait)"""
    min_stance: float = param(0.04, unit="s", ge=0)
    """zero-velocity runs shorter than this are dropped (mid-swing dips)"""
    crawl: CrawlLevels = param(CrawlLevels())
    """adaptive: levels while crawling (resting foot tilted beyond gait.crawl_tilt)"""

    @model_validator(mode="after")
    def _levels(self) -> "Detector":
        if self.kind == "adaptive" and not self.low < self.high:
            raise ValueError(f"low ({self.low:g}) must be below high ({self.high:g})")
        return self


class Imu(Params):
    """The IMU's own noise (datasheet) and rate."""

    accel_noise_density: float = param(100 * UG, unit="m/s^2/sqrt(Hz)", gt=0)
    """accelerometer white noise"""
    gyro_noise_density: float = param(0.005 * DEG, unit="rad/s/sqrt(Hz)", gt=0)
    """gyro white noise"""
    accel_bias_rw: float = param(0.04e-3 * G_STANDARD / 10.0, unit="m/s^3/sqrt(Hz)", ge=0)
    """accelerometer bias random walk (bias states)"""
    gyro_bias_rw: float = param(8.0 * DEG / 3600.0 / 10.0, unit="rad/s^2/sqrt(Hz)", ge=0)
    """gyro bias random walk (bias states)"""
    sample_rate: float | None = param(None, unit="Hz", gt=0)
    """nominal rate for the detector windows (default: from the first 50 sample intervals)"""


class Filter(Params):
    """The error-state Kalman filter."""

    accel_model_noise: float = param(0.5 * math.sqrt(0.005), unit="m/s^2/sqrt(Hz)", ge=0)
    """extra accelerometer process noise for strapdown model errors in the swing"""
    gyro_model_noise: float = param(0.5 * DEG * math.sqrt(0.005), unit="rad/s/sqrt(Hz)", ge=0)
    """extra gyro process noise"""
    zupt_sigma: float = param(0.01, unit="m/s", gt=0)
    """zero-velocity pseudo-measurement noise"""
    bias_states: bool = param(False)
    """estimate accelerometer and gyro biases"""
    accel_bias_sigma: float = param(0.0, unit="m/s^2", ge=0)
    """initial accelerometer bias uncertainty (bias states)"""
    gyro_bias_sigma: AngularRate = param(0.002, unit="rad/s", ge=0)
    """initial gyro bias uncertainty (bias states)"""
    max_gap: float = param(0.1, unit="s", gt=0)
    """longer sample intervals are integrated as this long (and counted)"""


class Zaru(Params):
    """Zero angular rate updates while standing still (they need ``filter.bias_states``)."""

    enabled: bool = param(False)
    """apply zero angular rate updates"""
    after: float = param(0.5, unit="s", ge=0)
    """stance duration before ZARU"""
    sigma: AngularRate = param(0.01, unit="rad/s", gt=0)
    """ZARU noise"""


class Alignment(Params):
    """Initial roll and pitch from gravity while the foot is still."""

    duration: float = param(0.1, unit="s", gt=0)
    """still time averaged for the initial roll/pitch"""
    min_duration: float = param(0.5, unit="s", gt=0)
    """if no still period lasts duration, the first still period at least this long is used when it
    ends (a diagnostic says how long it was)"""
    gyro_bias: bool = param(False)
    """take the mean gyro rate of the alignment as the gyro bias (needs a truly still start)"""
    tilt_sigma: Angle = param(0.1 * DEG, unit="rad", gt=0)
    """roll/pitch uncertainty after alignment"""


class Gravity(Params):
    """Magnitude of gravity: given, or WGS-84 normal gravity at a latitude and height."""

    magnitude: float = param(9.81, unit="m/s^2", gt=9.7, lt=9.9)
    """gravity magnitude (ignored when latitude is set)"""
    latitude: Angle | None = param(None, unit="rad", ge=-math.pi / 2, le=math.pi / 2)
    """use WGS-84 normal gravity at this geodetic latitude (north positive; YAML may say '52.2
    deg')"""
    altitude: float = param(0.0, unit="m")
    """height for normal gravity"""

    @property
    def g(self) -> float:
        """Gravity [m/s^2] these parameters give."""
        if self.latitude is None:
            return self.magnitude
        return normal_gravity(self.latitude, self.altitude)


class Height(Params):
    """Level-floor height: a sequence of level stances stays at its floor's height
    (zupt-extension, a height-only update: see ``eskf._level_floor``)."""

    correction: bool = param(True)
    """hold the height of level stance sequences at their floor's (vertical only: the horizontal
    track is the same either way)"""
    level_threshold: float = param(0.12, unit="m", gt=0)
    """height change from the previous stance (and from the floor) still counted as level floor;
    stairs rise more"""
    level_sigma: float = param(0.005, unit="m", gt=0)
    """noise of the level-floor height measurement"""
    stair_run: float = param(1.2, unit="m", gt=0)
    """a step at least this long horizontally is on a floor whatever its height change (one foot's
    stride on stairs spans two treads, four when taking them two at a time)"""


class Gait(Params):
    """Gait labels of the steps (``Odometry.motion``)."""

    stair_rise: float = param(0.10, unit="m", gt=0)
    """height change of a step labelled stairs"""
    crawl_tilt: Angle = param(60 * DEG, unit="rad", gt=0, le=math.pi)
    """tilt of the resting foot labelled crawl"""
    still_distance: float = param(0.05, unit="m", ge=0)
    """shorter steps are labelled still"""

    def thresholds(self) -> GaitThresholds:
        return GaitThresholds(stair_rise=self.stair_rise, crawl_tilt=self.crawl_tilt,
                              still_distance=self.still_distance)


class OdometryNoise(Params):
    """Errors the filter does not estimate: the step-to-step ones are added to each
    step's covariance; the lasting heading drift is published beside it."""

    yaw_rate_sigma: AngularRate = param(0.05 * DEG, unit="rad/s", ge=0)
    """turn-rate error independent from step to step, added to each step's heading variance as
    (sigma * step duration)^2"""
    length_sigma: float = param(0.02, unit="1", ge=0, lt=1)
    """relative step-length error added along each step's displacement covariance"""
    yaw_drift_rate_sigma: AngularRate = param(0.17 * DEG, unit="rad/s", ge=0)
    """spread of the heading drift rate that lasts the mission (residual and vibration-rectified
    gyro bias): published on every odometry message (Odometry.yaw_drift_rate_sigma, for
    consumers with a drift state) and counted in the poses' covariance; not in the increments'
    (it is no step-to-step error)"""

    def errors(self) -> UnmodelledErrors:
        return UnmodelledErrors(yaw_rate_sigma=self.yaw_rate_sigma,
                                length_sigma=self.length_sigma,
                                yaw_drift_rate_sigma=self.yaw_drift_rate_sigma)


class PoseIntegrity(IntegrityParams):
    """The ``pose`` and ``state`` outputs' covariance, protection radius and ``trusted``
    (``pose_uncertainty``): the odometry's errors (step-to-step and the lasting heading
    drift) accumulated, and the step-length scale error that lasts."""

    scale_sigma: float = param(0.03, unit="1", ge=0, lt=1)
    """spread of the step-length scale error that lasts the mission (all steps alike)"""
    position_sigma: float = param(0.1, unit="m", ge=0)
    """horizontal floor of the poses' uncertainty: the IMU is not the point tracked (a footprint,
    the wearer)"""
    drift_rate_sigma: float | None = param(0.2 * DEG, unit="rad/s", ge=0)
    """spread of the heading drift rate that lasts the mission, as the poses count it (the
    odometry's own, odometry.yaw_drift_rate_sigma, is not changed by it); null: the odometry's"""
    speed_from: float = param(2.0, unit="m/s", ge=0)
    """step speed above which the fast-gait heading drift acts (running)"""
    speed_drift_sigma: float = param(0.5 * DEG, unit="rad/s per m/s", ge=0)
    """spread of a heading drift rate that lasts the mission and acts in proportion to the step
    speed above speed_from (impacts: gyro g-sensitivity, vibration rectification, saturation)"""
    long_swing: float = param(2.0, unit="s", gt=0)
    """a step lasting longer missed zero-velocity updates (integrated unaided)"""
    long_swing_sigma: float = param(0.05, unit="1/s", ge=0)
    """horizontal error of such a step, relative to its length, per second beyond long_swing (each
    axis)"""
    max_speed: float | None = param(5.0, unit="m/s", gt=0)
    """a step faster than this is lost (stances missed, integrated unaided): horizontal error of
    its whole length (each axis); null: off"""
    max_clipped: float | None = param(0.15, unit="1", ge=0, le=1)
    """a step with a larger share of its samples saturated (accelerometer or gyro at full scale,
    ImuBlock flags) is lost (the sensor read less than the foot did): horizontal error of its
    whole length (each axis); null: off"""
    hold_peak: bool = param(True)
    """without a fix the horizontal uncertainty does not shrink: the covariance is raised by a
    circle to the largest horizontal variance so far (the drift nodes' errors cancel on the way
    back along an out-and-back, a real unit's do not)"""

    def uncertainty(self, errors: UnmodelledErrors) -> PoseUncertainty:
        """A fresh :class:`PoseUncertainty` with the odometry's ``errors``."""
        return PoseUncertainty(errors, self.scale_sigma, self.position_sigma, FastGaitErrors(
            speed_from=self.speed_from, speed_drift_sigma=self.speed_drift_sigma,
            long_swing=self.long_swing, long_swing_sigma=self.long_swing_sigma,
            max_speed=self.max_speed, max_clipped=self.max_clipped),
            drift_rate_sigma=self.drift_rate_sigma, hold_peak=self.hold_peak)


class Outputs(Params):
    """What is published besides the step odometry."""

    still_period: float = param(1.0, unit="s", gt=0)
    """odometry period while standing still"""
    step_settle: float = param(0.1, unit="s", ge=0)
    """a step is published this long into its stance (or at its end, if shorter), when the zero-
    velocity updates have settled its position; the full-rate state holds the stance there"""
    state_rate: float = param(0.0, unit="Hz", ge=0)
    """full-rate state output on port 'state' at this rate (0: off)"""
    retrospective_correction: bool = param(True)
    """state output: spread each stance's position correction back over the swing (zupt-extension)"""


#: Without a start pose the poses are in the INS's own 'odometry' frame, origin at the start.
DEFAULT_START = StartPose(mode="unknown")
ZuptInsStart = start_pose_type(DEFAULT_START, modes=("unknown", "pose"))


class ZuptInsParams(Params):
    detector: Detector = param(Detector())
    """zero-velocity detector"""
    imu: Imu = param(Imu())
    """IMU noise (datasheet) and rate"""
    filter: Filter = param(Filter())
    """error-state Kalman filter"""
    zaru: Zaru = param(Zaru())
    """zero angular rate updates at rest"""
    alignment: Alignment = param(Alignment())
    """initial attitude from gravity"""
    gravity: Gravity = param(Gravity())
    """gravity magnitude"""
    height: Height = param(Height())
    """level-floor height correction"""
    gait: Gait = param(Gait())
    """gait labels of the steps"""
    odometry: OdometryNoise = param(OdometryNoise())
    """unmodelled errors in the step covariance"""
    outputs: Outputs = param(Outputs())
    """rest odometry, full-rate state output"""
    integrity: PoseIntegrity = param(PoseIntegrity())
    """the poses' covariance, protection radius and trusted flag"""
    start: ZuptInsStart = param(DEFAULT_START)
    """mode 'unknown': poses in the INS's own 'odometry' frame, origin at the start; mode 'pose':
    placed in the building with the start position and the heading of the IMU x axis (a foot INS
    knows its walking direction only after some steps)"""

    @model_validator(mode="after")
    def _consistent(self) -> "ZuptInsParams":
        if self.zaru.enabled and not self.filter.bias_states:
            raise ValueError("zaru needs filter.bias_states: true (it estimates the gyro bias)")
        return self

    # -- numeric configurations --------------------------------------------------------
    def detector_config(self, rate: float) -> detectors.DetectorConfig:
        """Detector kernel configuration for an IMU at ``rate`` Hz."""
        d = self.detector
        w = max(3, int(round(d.window * rate)))
        w += 1 - w % 2
        samples = lambda s: int(round(s * rate))  # noqa: E731
        thr = d.threshold if d.threshold is not None else DEFAULT_THRESHOLDS.get(d.kind, 1.0)
        return detectors.DetectorConfig(
            kind=detectors.DETECTOR_KINDS[d.kind], window=w,
            sigma_a=self.imu.accel_noise_density, sigma_g=self.imu.gyro_noise_density,
            gravity=self.gravity.g, threshold=thr, low=10.0 ** d.low, high=10.0 ** d.high,
            kappa=d.kappa, prominence=d.prominence, ahead=samples(d.ahead),
            back=samples(d.swing_back), floor_back=samples(d.floor_back),
            min_stance=max(1, samples(d.min_stance)), crawl_up=math.cos(self.gait.crawl_tilt),
            crawl_low=10.0 ** d.crawl.low, crawl_high=10.0 ** d.crawl.high,
            crawl_kappa=d.crawl.kappa, crawl_prominence=d.crawl.prominence,
            crawl_min_stance=max(1, samples(d.crawl.min_stance)),
            crawl_half=min(samples(d.crawl.smoothing) // 2, samples(d.ahead)))

    def filter_config(self, rate: float) -> eskf.FilterConfig:
        """Filter kernel configuration for an IMU at ``rate`` Hz."""
        f, a = self.filter, self.alignment
        return eskf.FilterConfig(
            gravity=self.gravity.g,
            accel_noise=math.hypot(self.imu.accel_noise_density, f.accel_model_noise),
            gyro_noise=math.hypot(self.imu.gyro_noise_density, f.gyro_model_noise),
            accel_bias_rw=self.imu.accel_bias_rw, gyro_bias_rw=self.imu.gyro_bias_rw,
            bias_states=f.bias_states, init_accel_bias_sigma=f.accel_bias_sigma,
            init_gyro_bias_sigma=f.gyro_bias_sigma, init_tilt_sigma=a.tilt_sigma,
            init_yaw_sigma=a.tilt_sigma, zupt_sigma=f.zupt_sigma, zaru=self.zaru.enabled,
            zaru_after=self.zaru.after, zaru_sigma=self.zaru.sigma, zaru_gate=16.27,
            align_samples=max(1, int(round(a.duration * rate))),
            align_min_samples=max(1, int(round(min(a.duration, a.min_duration) * rate))),
            align_gyro_bias=a.gyro_bias, height_correction=self.height.correction,
            level_threshold=self.height.level_threshold, level_sigma=self.height.level_sigma,
            stair_run=self.height.stair_run,
            still_period=self.outputs.still_period, step_settle=self.outputs.step_settle,
            max_dt=f.max_gap)
