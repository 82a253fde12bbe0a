"""Parameters of the ZUPT-aided INS (one pydantic model: YAML schema, docs, defaults).

Sensor defaults are MicroStrain 3DM-GX5-25 datasheet values (the IMU of both real
datasets): accelerometer noise density 100 ug/sqrt(Hz), gyro noise density
0.005 deg/s/sqrt(Hz), bias instability 0.04 mg and 8 deg/h. The filter adds a model
error density on top (PyShoe's 0.5 m/s^2 and 0.5 deg/s per 200 Hz sample, as
densities): during a swing the strapdown model errors (vibration, scale factor,
heel-strike shocks, timing) are ~35x the accelerometer noise; with datasheet noise
alone the filter trusts the swing too much (see benchmarks/bench_ins_real_data.py).

How the detector defaults were chosen (``benchmarks/bench_ins_real_data.py --tune``
repeats the last step): the adaptive detector's form and its window lengths were worked
out while looking at all 56 VICON trials (the 0.7 s floor look-back: shorter than a
stride, so the floor follows a change of gait within one stride) and the 40 ms minimum
stance while looking at false mid-swing ZUPTs in the indoor walks; its level, kappa,
prominence and ceiling came from a grid over the even-numbered trials. A two-fold
coordinate descent from these defaults finds nothing that generalises: tuned on one
half, each change it makes does worse on the other half than the defaults. The fixed
detectors' default thresholds are their best single threshold on the even trials.
"""
from __future__ import annotations

import math
from typing import Literal

from pydantic import model_validator

from firenav_framework import Params, param

from . import detectors, eskf
from .steps import GaitThresholds, UnmodelledErrors

G_STANDARD = 9.80665
DEG = math.pi / 180.0
UG = 1e-6 * G_STANDARD

#: Fixed-detector thresholds used when ``threshold`` is not given: the best single
#: threshold (grid of quarter decades) over the even-numbered VICON trials.
DEFAULT_THRESHOLDS = {"shoe": 10 ** 8.25, "ared": 10 ** 8.25, "amvd": 10 ** 8.75}


def normal_gravity(latitude_deg: float, height_m: float = 0.0) -> float:
    """WGS-84 normal gravity [m/s^2] (Somigliana) with the free-air height correction."""
    s2 = math.sin(math.radians(latitude_deg)) ** 2
    g0 = 9.7803253359 * (1 + 0.00193185265241 * s2) / math.sqrt(1 - 0.00669437999013 * s2)
    return g0 - 3.086e-6 * height_m


class ZuptInsParams(Params):
    # -- zero-velocity detector ----------------------------------------------------------
    detector: Literal["adaptive", "shoe", "ared", "amvd"] = param(
        "adaptive", description="zero-velocity detector: adaptive (stance-relative SHOE "
        "threshold), or SHOE / ARED / AMVD with a fixed threshold")
    window: float = param(0.025, unit="s", gt=0, description="detector window, centred "
                          "(W = odd number of samples nearest; at least 3)")
    threshold: float | None = param(None, gt=0, description="fixed detectors: zero velocity "
                                    "when the statistic T is below this (default per detector)")
    zv_low: float = param(6.6, unit="log10 T", description="adaptive: SHOE statistic below "
                          "which the foot is surely still")
    zv_high: float = param(8.7, unit="log10 T", description="adaptive: SHOE statistic above "
                           "which the foot surely moves")
    zv_kappa: float = param(0.25, gt=0, lt=1, description="adaptive: threshold position "
                            "between stance floor and swing level (log scale)")
    zv_prominence: float = param(2.0, gt=0, unit="decades", description="adaptive: swing "
                                 "level above stance floor needed to call it a gait")
    zv_ahead: float = param(0.3, unit="s", ge=0, description="adaptive: look-ahead (latency)")
    zv_swing_back: float = param(1.5, unit="s", gt=0, description="adaptive: look-back of "
                                 "the swing level")
    zv_floor_back: float = param(0.7, unit="s", gt=0, description="adaptive: look-back of the "
                                 "stance floor (shorter than a stride: follows a change of gait)")
    min_stance: float = param(0.04, unit="s", ge=0, description="zero-velocity runs shorter "
                              "than this are dropped (mid-swing dips)")
    # -- sensor --------------------------------------------------------------------------
    accel_noise_density: float = param(100 * UG, unit="m/s^2/sqrt(Hz)", gt=0,
                                       description="accelerometer white noise (datasheet)")
    gyro_noise_density: float = param(0.005 * DEG, unit="rad/s/sqrt(Hz)", gt=0,
                                      description="gyro white noise (datasheet)")
    accel_model_noise: float = param(0.5 * math.sqrt(0.005), unit="m/s^2/sqrt(Hz)", ge=0,
                                     description="extra accelerometer process noise for "
                                     "strapdown model errors in the swing")
    gyro_model_noise: float = param(0.5 * DEG * math.sqrt(0.005), unit="rad/s/sqrt(Hz)", ge=0,
                                    description="extra gyro process noise")
    accel_bias_rw: float = param(0.04e-3 * G_STANDARD / 10.0, unit="m/s^3/sqrt(Hz)", ge=0,
                                 description="accelerometer bias random walk (bias states)")
    gyro_bias_rw: float = param(8.0 * DEG / 3600.0 / 10.0, unit="rad/s^2/sqrt(Hz)", ge=0,
                                description="gyro bias random walk (bias states)")
    sample_rate: float | None = param(None, unit="Hz", gt=0, description="nominal IMU rate "
                                      "for the detector windows (default: from the first "
                                      "50 sample intervals)")
    # -- filter --------------------------------------------------------------------------
    zupt_sigma: float = param(0.01, unit="m/s", gt=0, description="zero-velocity "
                              "pseudo-measurement noise")
    bias_states: bool = param(False, description="estimate accelerometer and gyro biases")
    init_accel_bias_sigma: float = param(0.0, unit="m/s^2", ge=0, description="initial "
                                         "accelerometer bias uncertainty (bias states)")
    init_gyro_bias_sigma: float = param(0.002, unit="rad/s", ge=0, description="initial gyro "
                                        "bias uncertainty (bias states)")
    zaru: bool = param(False, description="zero angular rate updates while standing still "
                       "(needs bias_states)")
    zaru_after: float = param(0.5, unit="s", ge=0, description="stance duration before ZARU")
    zaru_sigma: float = param(0.01, unit="rad/s", gt=0, description="ZARU noise")
    alignment_duration: float = param(0.1, unit="s", gt=0, description="still time averaged "
                                      "for the initial roll/pitch (alignment from gravity)")
    alignment_min_duration: float = param(0.5, unit="s", gt=0, description=(
        "if no still period lasts alignment_duration, the first still period at least "
        "this long is used when it ends (a diagnostic says how long it was)"))
    align_gyro_bias: bool = param(False, description="take the mean gyro rate of the "
                                  "alignment as the gyro bias (needs a truly still start)")
    init_tilt_sigma: float = param(0.1 * DEG, unit="rad", gt=0, description="roll/pitch "
                                   "uncertainty after alignment")
    gravity: float = param(9.81, unit="m/s^2", gt=9.7, lt=9.9, description="gravity "
                           "magnitude (ignored when latitude is set)")
    latitude: float | None = param(None, unit="deg", ge=-90, le=90, description="use WGS-84 "
                                   "normal gravity at this latitude")
    altitude: float = param(0.0, unit="m", description="height for normal gravity")
    max_gap: float = param(0.1, unit="s", gt=0, description="longer sample intervals are "
                           "integrated as this long (and counted)")
    # -- zupt-extension options ------------------------------------------------------------
    retrospective_correction: bool = param(True, description="spread each stance's position "
                                           "correction back over the swing (full-rate state)")
    height_correction: bool = param(False, description="level floors: pull a stance back to "
                                    "the previous stance height when they differ by less "
                                    "than level_threshold")
    level_threshold: float = param(0.08, unit="m", gt=0, description="height change per step "
                                   "still counted as level floor")
    level_sigma: float = param(0.01, unit="m", gt=0, description="noise of the level-floor "
                               "height measurement")
    # -- outputs -------------------------------------------------------------------------
    still_period: float = param(1.0, unit="s", gt=0, description="odometry period while "
                                "standing still")
    state_rate: float = param(0.0, unit="Hz", ge=0, description="full-rate state output on "
                              "port 'state' at this rate (0: off)")
    initial_position: tuple[float, float, float] | None = param(
        None, unit="m", description="building-frame ENU position of the start; without it "
        "(and initial_heading) the poses are in the INS's own 'odometry' frame, origin at "
        "the start")
    initial_heading: float | None = param(None, unit="rad", description="building-frame "
                                          "heading of the IMU x axis at the start")
    stair_rise: float = param(0.10, unit="m", gt=0, description="height change of a step "
                              "labelled stairs")
    crawl_tilt: float = param(60 * DEG, unit="rad", gt=0, le=math.pi, description="tilt of "
                              "the resting foot labelled crawl")
    still_distance: float = param(0.05, unit="m", ge=0, description="shorter steps are "
                                  "labelled still")
    odometry_yaw_rate_sigma: float = param(0.05 * DEG, unit="rad/s", ge=0, description=(
        "residual gyro bias the filter does not estimate, added to each step's heading "
        "variance as (sigma * step duration)^2"))
    odometry_length_sigma: float = param(0.02, ge=0, lt=1, description=(
        "relative step-length error added along each step's displacement covariance"))

    @model_validator(mode="after")
    def _consistent(self) -> "ZuptInsParams":
        if self.zaru and not self.bias_states:
            raise ValueError("zaru needs bias_states: true (it estimates the gyro bias)")
        if self.detector == "adaptive" and not self.zv_low < self.zv_high:
            raise ValueError(f"zv_low ({self.zv_low:g}) must be below zv_high ({self.zv_high:g})")
        return self

    # -- numeric configurations --------------------------------------------------------
    @property
    def g(self) -> float:
        return self.gravity if self.latitude is None else normal_gravity(self.latitude,
                                                                         self.altitude)

    def detector_config(self, rate: float) -> detectors.DetectorConfig:
        """Detector kernel configuration for an IMU at ``rate`` Hz."""
        w = max(3, int(round(self.window * rate)))
        w += 1 - w % 2
        samples = lambda s: int(round(s * rate))  # noqa: E731
        thr = self.threshold if self.threshold is not None else DEFAULT_THRESHOLDS.get(
            self.detector, 1.0)
        return detectors.DetectorConfig(
            kind=detectors.DETECTOR_KINDS[self.detector], window=w,
            sigma_a=self.accel_noise_density, sigma_g=self.gyro_noise_density, gravity=self.g,
            threshold=thr, low=10.0 ** self.zv_low, high=10.0 ** self.zv_high, kappa=self.zv_kappa,
            prominence=self.zv_prominence, ahead=samples(self.zv_ahead),
            back=samples(self.zv_swing_back), floor_back=samples(self.zv_floor_back),
            min_stance=max(1, samples(self.min_stance)))

    def filter_config(self, rate: float) -> eskf.FilterConfig:
        """Filter kernel configuration for an IMU at ``rate`` Hz."""
        return eskf.FilterConfig(
            gravity=self.g,
            accel_noise=math.hypot(self.accel_noise_density, self.accel_model_noise),
            gyro_noise=math.hypot(self.gyro_noise_density, self.gyro_model_noise),
            accel_bias_rw=self.accel_bias_rw, gyro_bias_rw=self.gyro_bias_rw,
            bias_states=self.bias_states, init_accel_bias_sigma=self.init_accel_bias_sigma,
            init_gyro_bias_sigma=self.init_gyro_bias_sigma, init_tilt_sigma=self.init_tilt_sigma,
            init_yaw_sigma=self.init_tilt_sigma, zupt_sigma=self.zupt_sigma, zaru=self.zaru,
            zaru_after=self.zaru_after, zaru_sigma=self.zaru_sigma, zaru_gate=16.27,
            align_samples=max(1, int(round(self.alignment_duration * rate))),
            align_min_samples=max(1, int(round(min(self.alignment_duration,
                                                   self.alignment_min_duration) * rate))),
            align_gyro_bias=self.align_gyro_bias, height_correction=self.height_correction,
            level_threshold=self.level_threshold, level_sigma=self.level_sigma,
            still_period=self.still_period, max_dt=self.max_gap)

    def gait(self) -> GaitThresholds:
        return GaitThresholds(stair_rise=self.stair_rise, crawl_tilt=self.crawl_tilt,
                              still_distance=self.still_distance)

    def unmodelled(self) -> UnmodelledErrors:
        return UnmodelledErrors(yaw_rate_sigma=self.odometry_yaw_rate_sigma,
                                length_sigma=self.odometry_length_sigma)
