"""IMU error specifications in datasheet units, and the named grades we ship.

A grade states what a datasheet states, in the datasheet's own units, so a user can
copy numbers from a PDF into a scenario (``imu: {grade: xsens_mti3, gyro:
{turn_on_bias_dps: 0.1}}``). :mod:`.imu_errors` converts to SI and draws the errors.

Meaning of the fields (1-sigma unless said otherwise):

* ``noise_density``: white noise density (angle / velocity random walk); the Allan
  deviation at averaging time tau is ``noise_density / sqrt(tau)``.
* ``bias_instability``: the floor of the Allan deviation (in-run bias stability),
  simulated as a first-order Gauss-Markov bias whose Allan-deviation peak equals it,
  reached at about 1.9 x ``bias_tau_s``.
* ``rate_random_walk`` / ``accel_random_walk``: bias random walk density.
* ``turn_on_bias``: constant bias, different at every power-up (bias repeatability).
* ``thermal_drift``: bias change per kelvin; with a scenario temperature change
  (warm boot, heat near a fire) it is a slow bias ramp.
* ``scale_factor_pct``, ``misalignment_deg``: constant per unit, drawn per run;
  ``nonlinearity_pct`` (of full scale): a quadratic, sign-keeping error
  ``k x |x| / range`` whose largest value within the range is that percentage.
* ``g_sensitivity``: gyro bias per g of specific force (linear acceleration effect).
* ``vibration_bias``: gyro bias under vibration (vibration rectification: what impacts
  and the strap's ringing do to a MEMS gyro), at 1 g rms of the specific force above
  10 Hz; it grows with the square root of that rms (fitted on the real walks and runs:
  :mod:`.imu_errors`). Its direction is drawn per run and it vanishes at rest, so a
  still start cannot calibrate it away.
* ``range``: saturation; ``resolution``: quantisation step (0 = none).

The shipped grades live in ``imu_grades.yaml``; where a datasheet is silent, the
assumption is stated next to the number there.
"""
from __future__ import annotations

from pathlib import Path
from typing import Literal

import yaml
from pydantic import ConfigDict, Field, model_validator

from ..field_docs import DescribedModel


class _Spec(DescribedModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class _AxisSpec(_Spec):
    """The errors a gyroscope and an accelerometer axis have in common."""

    bias_tau_s: float = Field(100.0, gt=0)
    """bias correlation time [s]"""
    scale_factor_pct: float = Field(0.1, ge=0)
    """[%]"""
    nonlinearity_pct: float = Field(0.0, ge=0)
    """[% of full scale]"""
    misalignment_deg: float = Field(0.1, ge=0)
    """cross-axis [deg]"""


class GyroSpec(_AxisSpec):
    """Gyroscope errors per axis, datasheet units."""

    range_dps: float = Field(2000.0, gt=0)
    """full scale [deg/s]"""
    noise_density_dps_rthz: float = Field(0.007, ge=0)
    """[deg/s/sqrt(Hz)]"""
    bias_instability_dph: float = Field(10.0, ge=0)
    """Allan floor [deg/h]"""
    rate_random_walk_dps_rts: float = Field(0.0, ge=0)
    """[deg/s/sqrt(s)]"""
    turn_on_bias_dps: float = Field(0.1, ge=0)
    """bias repeatability [deg/s]"""
    thermal_drift_dps_per_k: float = Field(0.0, ge=0)
    """[deg/s/K]"""
    g_sensitivity_dps_per_g: float = Field(0.0, ge=0)
    """[deg/s/g]"""
    vibration_bias_dps: float = Field(0.0, ge=0)
    """bias at 1 g rms of vibration above 10 Hz, growing with its square root [deg/s]"""
    resolution_dps: float = Field(0.0, ge=0)
    """quantisation step [deg/s]"""


class AccelSpec(_AxisSpec):
    """Accelerometer errors per axis, datasheet units."""

    range_g: float = Field(16.0, gt=0)
    """full scale [g]"""
    noise_density_ug_rthz: float = Field(120.0, ge=0)
    """[ug/sqrt(Hz)]"""
    bias_instability_ug: float = Field(30.0, ge=0)
    """Allan floor [ug]"""
    random_walk_ug_rts: float = Field(0.0, ge=0)
    """bias random walk [ug/sqrt(s)]"""
    turn_on_bias_mg: float = Field(2.0, ge=0)
    """bias repeatability [mg]"""
    thermal_drift_mg_per_k: float = Field(0.0, ge=0)
    """[mg/K]"""
    resolution_mg: float = Field(0.0, ge=0)
    """quantisation step [mg]"""


class MagSpec(_Spec):
    """Magnetometer errors (the indoor field disturbance is a scenario property)."""

    range_ut: float = Field(800.0, gt=0)
    """full scale [uT]"""
    noise_ut: float = Field(0.5, ge=0)
    """white noise per sample [uT]"""
    hard_iron_ut: float = Field(5.0, ge=0)
    """residual hard-iron offset [uT]"""
    soft_iron_pct: float = Field(2.0, ge=0)
    """residual soft-iron gain/coupling [%]"""


class WornProfile(_Spec):
    """How a unit strapped on a firefighter's boot differs from its datasheet.

    ``gyro`` / ``accel``: :class:`GyroSpec` / :class:`AccelSpec` fields that change (the
    rest stay the datasheet's); ``source``: where the numbers come from.
    """

    gyro: dict[str, float] = Field(default_factory=dict)
    accel: dict[str, float] = Field(default_factory=dict)
    source: str = ""

    @model_validator(mode="after")
    def _fields(self) -> "WornProfile":
        GyroSpec(**self.gyro)
        AccelSpec(**self.accel)
        return self


class ImuGrade(_Spec):
    """A named IMU with its error specification and where the numbers come from.

    ``gyro``, ``accel``, ``mag``: the datasheet; ``as_worn``: what changes on a boot in
    the field (:data:`IMU_ERRORS`, :func:`error_specs`).
    """

    name: str
    description: str = ""
    source: str = ""
    gyro: GyroSpec = GyroSpec()
    accel: AccelSpec = AccelSpec()
    mag: MagSpec = MagSpec()
    as_worn: WornProfile = WornProfile()


def _shipped_grades() -> dict[str, ImuGrade]:
    """The grades of ``imu_grades.yaml`` beside this module, by name, in file order."""
    entries = yaml.safe_load(Path(__file__).with_name("imu_grades.yaml").read_text("utf-8"))
    return {g.name: g for g in map(ImuGrade.model_validate, entries)}


#: The shipped grades (``imu_grades.yaml``: one entry per device, datasheet units, with
#: the source of every number), by name.
GRADES: dict[str, ImuGrade] = _shipped_grades()

#: Generic grade names (the issue's consumer / industrial / tactical) -> shipped grade.
ALIASES = {"industrial": "xsens_mti3"}


def get_grade(name: str) -> ImuGrade:
    """The named grade (``consumer``, ``industrial``, ``tactical`` or a device name)."""
    key = ALIASES.get(name, name)
    try:
        return GRADES[key]
    except KeyError:
        known = ", ".join(sorted([*GRADES, *ALIASES]))
        raise ValueError(f"unknown IMU grade '{name}'; known grades: {known}") from None


#: The sensor errors a scenario can ask for (``sensors.imu.errors``):
#:
#: * ``as_worn`` (default): the unit on a boot in the field, uncalibrated: the datasheet
#:   with the grade's :class:`WornProfile` on top;
#: * ``calibrated``: as worn, with the gyro turn-on bias replaced by what a still start
#:   of a few seconds leaves (:data:`STILL_START_RESIDUAL_DPS`); the errors that only
#:   appear in motion (vibration, scale factor, warm-up) stay;
#: * ``datasheet``: the datasheet numbers alone (a unit on a lab bench);
#: * ``ideal``: no errors at all (range kept: a foot can still saturate it).
IMU_ERRORS = ("as_worn", "calibrated", "datasheet", "ideal")
ImuErrors = Literal["as_worn", "calibrated", "datasheet", "ideal"]

#: Gyro bias left by a still-start calibration [deg/s, 1 sigma per axis]: the real
#: recordings' still-start gyro means vary by about this much between trials of one unit
#: (the foot settles and shifts its weight while "standing still").
STILL_START_RESIDUAL_DPS = 0.05


def error_specs(grade: ImuGrade, errors: str = "as_worn", *, gyro: dict | None = None,
                accel: dict | None = None, mag: dict | None = None
                ) -> tuple[GyroSpec, AccelSpec, MagSpec]:
    """The gyro, accelerometer and magnetometer specs of ``grade`` under ``errors``
    (one of :data:`IMU_ERRORS`), with a scenario's field overrides on top."""
    if errors not in IMU_ERRORS:
        raise ValueError(f"unknown IMU errors {errors!r}; one of {', '.join(IMU_ERRORS)}")
    worn = errors in ("as_worn", "calibrated")
    g = {**grade.gyro.model_dump(), **(grade.as_worn.gyro if worn else {}), **(gyro or {})}
    a = {**grade.accel.model_dump(), **(grade.as_worn.accel if worn else {}), **(accel or {})}
    m = {**grade.mag.model_dump(), **(mag or {})}
    if errors == "calibrated":
        g["turn_on_bias_dps"] = STILL_START_RESIDUAL_DPS
    if errors == "ideal":
        g = {k: (v if k == "range_dps" else (100.0 if k == "bias_tau_s" else 0.0))
             for k, v in g.items()}
        a = {k: (v if k == "range_g" else (100.0 if k == "bias_tau_s" else 0.0))
             for k, v in a.items()}
        m = {k: (v if k == "range_ut" else 0.0) for k, v in m.items()}
    return GyroSpec(**g), AccelSpec(**a), MagSpec(**m)
