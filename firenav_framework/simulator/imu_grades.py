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

Where a datasheet is silent we state the assumption next to the number.
"""
from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator


class _Spec(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class GyroSpec(_Spec):
    """Gyroscope errors per axis, datasheet units."""

    range_dps: float = Field(2000.0, gt=0, description="full scale [deg/s]")
    noise_density_dps_rthz: float = Field(0.007, ge=0, description="[deg/s/sqrt(Hz)]")
    bias_instability_dph: float = Field(10.0, ge=0, description="Allan floor [deg/h]")
    bias_tau_s: float = Field(100.0, gt=0, description="bias correlation time [s]")
    rate_random_walk_dps_rts: float = Field(0.0, ge=0, description="[deg/s/sqrt(s)]")
    turn_on_bias_dps: float = Field(0.1, ge=0, description="bias repeatability [deg/s]")
    thermal_drift_dps_per_k: float = Field(0.0, ge=0, description="[deg/s/K]")
    scale_factor_pct: float = Field(0.1, ge=0, description="[%]")
    nonlinearity_pct: float = Field(0.0, ge=0, description="[% of full scale]")
    misalignment_deg: float = Field(0.1, ge=0, description="cross-axis [deg]")
    g_sensitivity_dps_per_g: float = Field(0.0, ge=0, description="[deg/s/g]")
    vibration_bias_dps: float = Field(0.0, ge=0, description="bias at 1 g rms of vibration "
                                      "above 10 Hz, growing with its square root [deg/s]")
    resolution_dps: float = Field(0.0, ge=0, description="quantisation step [deg/s]")


class AccelSpec(_Spec):
    """Accelerometer errors per axis, datasheet units."""

    range_g: float = Field(16.0, gt=0, description="full scale [g]")
    noise_density_ug_rthz: float = Field(120.0, ge=0, description="[ug/sqrt(Hz)]")
    bias_instability_ug: float = Field(30.0, ge=0, description="Allan floor [ug]")
    bias_tau_s: float = Field(100.0, gt=0, description="bias correlation time [s]")
    random_walk_ug_rts: float = Field(0.0, ge=0, description="bias random walk [ug/sqrt(s)]")
    turn_on_bias_mg: float = Field(2.0, ge=0, description="bias repeatability [mg]")
    thermal_drift_mg_per_k: float = Field(0.0, ge=0, description="[mg/K]")
    scale_factor_pct: float = Field(0.1, ge=0, description="[%]")
    nonlinearity_pct: float = Field(0.0, ge=0, description="[% of full scale]")
    misalignment_deg: float = Field(0.1, ge=0, description="cross-axis [deg]")
    resolution_mg: float = Field(0.0, ge=0, description="quantisation step [mg]")


class MagSpec(_Spec):
    """Magnetometer errors (the indoor field disturbance is a scenario property)."""

    range_ut: float = Field(800.0, gt=0, description="full scale [uT]")
    noise_ut: float = Field(0.5, ge=0, description="white noise per sample [uT]")
    hard_iron_ut: float = Field(5.0, ge=0, description="residual hard-iron offset [uT]")
    soft_iron_pct: float = Field(2.0, ge=0, description="residual soft-iron gain/coupling [%]")


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


GRADES: dict[str, ImuGrade] = {g.name: g for g in [
    ImuGrade(
        name='xsens_mti3',
        description='Xsens MTi-3 (MTi 1-series), the foot IMU of the search-pattern paper '
                    '(Sec. V-A)',
        source='Xsens MTi 1-series datasheet: gyro +-2000 deg/s, in-run bias 10 deg/h, '
               '0.007 deg/s/rtHz, non-linearity 0.1 %FS; accel +-16 g, in-run bias 0.03 '
               'mg, 120 ug/rtHz, non-linearity 0.5 %FS. Turn-on bias, scale factor and '
               'thermal drift: typical for factory-calibrated MEMS of this class '
               '(assumed).',
        gyro=GyroSpec(range_dps=2000.0, noise_density_dps_rthz=0.007, bias_instability_dph=10.0,
                      bias_tau_s=60.0, rate_random_walk_dps_rts=0.0, turn_on_bias_dps=0.2,
                      thermal_drift_dps_per_k=0.005, scale_factor_pct=0.1, nonlinearity_pct=0.1,
                      misalignment_deg=0.1, g_sensitivity_dps_per_g=0.003, resolution_dps=0.0),
        accel=AccelSpec(range_g=16.0, noise_density_ug_rthz=120.0, bias_instability_ug=30.0,
                        bias_tau_s=60.0, random_walk_ug_rts=0.0, turn_on_bias_mg=3.0,
                        thermal_drift_mg_per_k=0.1, scale_factor_pct=0.1, nonlinearity_pct=0.5,
                        misalignment_deg=0.1, resolution_mg=0.0),
        as_worn=WornProfile(
            gyro={"vibration_bias_dps": 0.31},
            source='the MicroStrain figures measured on the real recordings (a MEMS IMU of '
                   'the same class and price)'),
    ),
    ImuGrade(
        name='microstrain_3dm_gx5_25',
        description='MicroStrain 3DM-GX5-25, the IMU of the real recordings in '
                    '../shared/data',
        source='LORD MicroStrain 3DM-GX5-25 datasheet: gyro bias instability 8 deg/h, '
               'noise 0.005 deg/s/rtHz, initial bias +-0.04 deg/s, scale factor stability '
               '0.05 %; accel bias instability 0.04 mg, initial bias +-2 mg, 25 ug/rtHz. '
               'Gyro range +-900 deg/s (ordering option: the real trials reach 561 deg/s).',
        gyro=GyroSpec(range_dps=900.0, noise_density_dps_rthz=0.005, bias_instability_dph=8.0,
                      bias_tau_s=100.0, rate_random_walk_dps_rts=0.0, turn_on_bias_dps=0.04,
                      thermal_drift_dps_per_k=0.002, scale_factor_pct=0.05,
                      nonlinearity_pct=0.02, misalignment_deg=0.05,
                      g_sensitivity_dps_per_g=0.002, resolution_dps=0.0),
        accel=AccelSpec(range_g=8.0, noise_density_ug_rthz=25.0, bias_instability_ug=40.0,
                        bias_tau_s=100.0, random_walk_ug_rts=0.0, turn_on_bias_mg=2.0,
                        thermal_drift_mg_per_k=0.05, scale_factor_pct=0.05,
                        nonlinearity_pct=0.02, misalignment_deg=0.05, resolution_mg=0.0),
        as_worn=WornProfile(
            gyro={"vibration_bias_dps": 0.31},
            accel={"noise_density_ug_rthz": 80.0},
            source='measured on the real recordings in ../shared/data '
                   '(benchmarks/bench_sim_realism.py): the heading drift of the same ZUPT INS '
                   'on the walks, with and without a still-start gyro calibration, and on '
                   'the runs (vibration rectification: a still start does not remove it, and '
                   'it grows from walking to running); accelerometer noise standing still '
                   '(70-100 ug/rtHz)'),
    ),
    ImuGrade(
        name='lsm6ds33',
        description="ST LSM6DS33 consumer MEMS at +-2000 deg/s / +-8 g, the ORCA paper's "
                    "IMU (Sec. 3.1), before the user's own calibration",
        source='ST LSM6DS33 datasheet: rate noise density 7 mdps/rtHz, zero-rate level '
               '+-10 dps at 2000 dps FS, zero-rate change 0.05 dps/K; accel noise 90 '
               'ug/rtHz, zero-g offset +-40 mg, 0.061 mg/LSB at 2 g (0.244 mg at 8 g), 70 '
               'mdps/LSB at 2000 dps. In-run bias instability not specified: 15 deg/h '
               'assumed (typical of consumer MEMS gyros); sensitivity tolerance +-1..2 % '
               'taken as scale factor.',
        gyro=GyroSpec(range_dps=2000.0, noise_density_dps_rthz=0.007, bias_instability_dph=15.0,
                      bias_tau_s=40.0, rate_random_walk_dps_rts=0.0, turn_on_bias_dps=10.0,
                      thermal_drift_dps_per_k=0.05, scale_factor_pct=1.5, nonlinearity_pct=0.2,
                      misalignment_deg=1.0, g_sensitivity_dps_per_g=0.1, resolution_dps=0.07),
        accel=AccelSpec(range_g=8.0, noise_density_ug_rthz=90.0, bias_instability_ug=80.0,
                        bias_tau_s=40.0, random_walk_ug_rts=0.0, turn_on_bias_mg=40.0,
                        thermal_drift_mg_per_k=0.5, scale_factor_pct=1.5, nonlinearity_pct=0.5,
                        misalignment_deg=1.0, resolution_mg=0.244),
        as_worn=WornProfile(
            gyro={"vibration_bias_dps": 0.62},
            source='datasheet zero-rate level as the turn-on bias (no factory trim); '
                   'vibration rectification twice the MicroStrain figure (consumer MEMS, '
                   'assumed)'),
    ),
    ImuGrade(
        name='xsens_mtx',
        description='Xsens MTx (2007), the inertial modules of the RFID paper (EPFL '
                    'LIAISON)',
        source='Xsens MTi/MTx user manual MT0100P: gyro +-1200 deg/s (MTx default) noise '
               '0.1 deg/s/rtHz, bias stability 1 deg/s (1 sigma, taken as turn-on and '
               'thermal), accel +-50 m/s^2, noise 0.002 m/s^2/rtHz, bias stability 0.02 '
               'm/s^2. In-run Allan floor not given: 40 deg/h assumed for MEMS gyros of '
               'that era.',
        gyro=GyroSpec(range_dps=1200.0, noise_density_dps_rthz=0.1, bias_instability_dph=40.0,
                      bias_tau_s=60.0, rate_random_walk_dps_rts=0.0, turn_on_bias_dps=1.0,
                      thermal_drift_dps_per_k=0.02, scale_factor_pct=0.5, nonlinearity_pct=0.1,
                      misalignment_deg=0.3, g_sensitivity_dps_per_g=0.1, resolution_dps=0.0),
        accel=AccelSpec(range_g=5.1, noise_density_ug_rthz=204.0, bias_instability_ug=200.0,
                        bias_tau_s=60.0, random_walk_ug_rts=0.0, turn_on_bias_mg=2.0,
                        thermal_drift_mg_per_k=0.3, scale_factor_pct=0.5, nonlinearity_pct=0.2,
                        misalignment_deg=0.3, resolution_mg=0.0),
        as_worn=WornProfile(
            gyro={"vibration_bias_dps": 0.62},
            source='datasheet bias stability as the turn-on bias; vibration rectification '
                   'twice the MicroStrain figure (2007 MEMS, assumed)'),
    ),
    ImuGrade(
        name='xsens_mtw',
        description='Xsens MTw wireless tracker, the IMU of the ZUPT-extension paper '
                    '(Method)',
        source='Xsens MTw user manual: gyro +-2000 deg/s, noise 0.01 deg/s/rtHz, in-run '
               'bias stability 10 deg/h; accel +-16 g, noise 200 ug/rtHz, bias stability '
               '0.1 mg. Turn-on bias and thermal drift typical of the class (assumed).',
        gyro=GyroSpec(range_dps=2000.0, noise_density_dps_rthz=0.01, bias_instability_dph=10.0,
                      bias_tau_s=60.0, rate_random_walk_dps_rts=0.0, turn_on_bias_dps=0.2,
                      thermal_drift_dps_per_k=0.01, scale_factor_pct=0.2, nonlinearity_pct=0.1,
                      misalignment_deg=0.2, g_sensitivity_dps_per_g=0.005, resolution_dps=0.0),
        accel=AccelSpec(range_g=16.0, noise_density_ug_rthz=200.0, bias_instability_ug=100.0,
                        bias_tau_s=60.0, random_walk_ug_rts=0.0, turn_on_bias_mg=5.0,
                        thermal_drift_mg_per_k=0.1, scale_factor_pct=0.2, nonlinearity_pct=0.2,
                        misalignment_deg=0.2, resolution_mg=0.0),
        as_worn=WornProfile(
            gyro={"vibration_bias_dps": 0.31},
            source='the MicroStrain figures measured on the real recordings (a MEMS IMU of '
                   'the same class)'),
    ),
    ImuGrade(
        name='consumer',
        description='Generic consumer MEMS (smartphone/wearable class, e.g. InvenSense '
                    'MPU-9250, Bosch BMI160), factory trim only',
        source='MPU-9250 / BMI160 datasheets: gyro noise 0.008-0.01 deg/s/rtHz, zero-rate '
               'offset +-3..5 deg/s, offset drift 0.08 deg/s/K (BMI160), bias stability 6 '
               'deg/h typ (BMI160); accel noise 150-300 ug/rtHz, zero-g offset +-40..60 '
               'mg, sensitivity tolerance +-1..3 %.',
        gyro=GyroSpec(range_dps=2000.0, noise_density_dps_rthz=0.01, bias_instability_dph=20.0,
                      bias_tau_s=30.0, rate_random_walk_dps_rts=0.0, turn_on_bias_dps=3.0,
                      thermal_drift_dps_per_k=0.05, scale_factor_pct=2.0, nonlinearity_pct=0.2,
                      misalignment_deg=1.0, g_sensitivity_dps_per_g=0.1, resolution_dps=0.061),
        accel=AccelSpec(range_g=16.0, noise_density_ug_rthz=200.0, bias_instability_ug=100.0,
                        bias_tau_s=30.0, random_walk_ug_rts=0.0, turn_on_bias_mg=40.0,
                        thermal_drift_mg_per_k=0.5, scale_factor_pct=2.0, nonlinearity_pct=0.5,
                        misalignment_deg=1.0, resolution_mg=0.49),
        as_worn=WornProfile(
            gyro={"vibration_bias_dps": 0.62},
            source='datasheet zero-rate offset as the turn-on bias (factory trim only); '
                   'vibration rectification twice the MicroStrain figure (assumed)'),
    ),
    ImuGrade(
        name='tactical',
        description='Tactical-grade MEMS IMU with foot-compatible range (Analog Devices '
                    'ADIS16495-3 class)',
        source='ADIS16495-3 datasheet: gyro +-2000 deg/s, in-run bias 1.6 deg/h, ARW 0.12 '
               'deg/rt(h) (= 0.002 deg/s/rtHz); accel +-8 g, in-run bias 3.2 ug, VRW 0.008 '
               'm/s/rt(h) (= 14 ug/rtHz).',
        gyro=GyroSpec(range_dps=2000.0, noise_density_dps_rthz=0.002, bias_instability_dph=1.6,
                      bias_tau_s=200.0, rate_random_walk_dps_rts=0.0, turn_on_bias_dps=0.01,
                      thermal_drift_dps_per_k=0.0005, scale_factor_pct=0.02,
                      nonlinearity_pct=0.01, misalignment_deg=0.01,
                      g_sensitivity_dps_per_g=0.0005, resolution_dps=0.0),
        accel=AccelSpec(range_g=8.0, noise_density_ug_rthz=14.0, bias_instability_ug=3.2,
                        bias_tau_s=200.0, random_walk_ug_rts=0.0, turn_on_bias_mg=0.5,
                        thermal_drift_mg_per_k=0.01, scale_factor_pct=0.02,
                        nonlinearity_pct=0.01, misalignment_deg=0.01, resolution_mg=0.0),
        as_worn=WornProfile(
            gyro={"vibration_bias_dps": 0.02},
            source='vibration rectification from the ADIS16495 datasheet class (0.02 deg/s '
                   'per g rms, assumed); the datasheet otherwise'),
    ),
]}

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
