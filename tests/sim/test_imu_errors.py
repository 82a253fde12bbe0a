"""The IMU error model produces the statistics its specification states."""
from __future__ import annotations

import numpy as np
import pytest

from firenav_framework.simulator.imu_errors import (DEG, G0, GM_PEAK, _gm_allan_ratio,
                                                    allan_deviation, allan_model, corrupt,
                                                    draw_errors, gauss_markov)
from firenav_framework.simulator.imu_grades import GRADES, AccelSpec, GyroSpec, get_grade


def test_gauss_markov_allan_formula_has_its_textbook_limits():
    # unit variance: white-noise-like for T >> tau (2 tau / T); for T << tau a random walk
    # of density q^2 = 2 / tau, whose Allan variance is q^2 T / 3 = 2 T / (3 tau)
    assert _gm_allan_ratio(np.array([1e3]))[0] ** 2 == pytest.approx(2e-3, rel=2e-3)
    assert _gm_allan_ratio(np.array([1e-3]))[0] ** 2 == pytest.approx(2e-3 / 3, rel=2e-3)
    assert 0.60 < GM_PEAK < 0.63


@pytest.mark.parametrize("spec", [
    GyroSpec(noise_density_dps_rthz=0.007, bias_instability_dph=10, bias_tau_s=30,
             turn_on_bias_dps=0, scale_factor_pct=0, misalignment_deg=0),
    GyroSpec(noise_density_dps_rthz=0.01, bias_instability_dph=0, rate_random_walk_dps_rts=2e-4,
             turn_on_bias_dps=0, scale_factor_pct=0, misalignment_deg=0),
])
def test_gyro_noise_statistics_match_the_configured_densities_via_allan_deviation(spec):
    fs = 100.0
    n = int(2 * 3600 * fs)
    y, _, _ = corrupt(np.zeros((n, 3)), spec, fs, np.random.default_rng(7))
    taus = np.array([0.05, 0.1, 1.0, 10.0, 30.0, 60.0, 120.0, 300.0])
    used, adev = np.transpose([allan_deviation(y[:, i], fs, taus) for i in range(3)], (1, 0, 2))
    used = used[0]
    measured = np.sqrt(np.mean(adev ** 2, axis=0))
    expected = allan_model(used, spec.noise_density_dps_rthz * DEG,
                           spec.bias_instability_dph * DEG / 3600, spec.bias_tau_s,
                           spec.rate_random_walk_dps_rts * DEG)
    ratio = measured / expected
    # short taus: thousands of clusters, a few % of scatter; long taus: tens of clusters
    assert np.all(np.abs(ratio[used <= 10] - 1) < 0.06), ratio
    assert np.all(np.abs(ratio[used > 10] - 1) < 0.25), ratio
    # white noise alone: adev(tau) = N / sqrt(tau), the density itself at 1 s
    assert measured[used == 1.0][0] == pytest.approx(spec.noise_density_dps_rthz * DEG, rel=0.1)


def test_bias_instability_is_the_allan_floor_of_the_bias():
    spec = AccelSpec(noise_density_ug_rthz=0.0, bias_instability_ug=50, bias_tau_s=20,
                     turn_on_bias_mg=0, scale_factor_pct=0, misalignment_deg=0)
    fs = 50.0
    y, _, _ = corrupt(np.zeros((int(3 * 3600 * fs), 3)), spec, fs, np.random.default_rng(3))
    taus = np.geomspace(1, 400, 25)
    used, adev = allan_deviation(y[:, 0], fs, taus)
    peak = adev.max()
    assert peak == pytest.approx(50e-6 * G0, rel=0.2)
    assert 15 < used[adev.argmax()] < 90   # about 1.9 tau


def test_constant_errors_follow_their_one_sigma_specs():
    spec = GRADES["lsm6ds33"].gyro
    draws = [draw_errors(spec, np.random.default_rng(i)) for i in range(3000)]
    on = np.array([d.turn_on_bias for d in draws])
    m = np.array([d.matrix for d in draws])
    assert on.std() == pytest.approx(spec.turn_on_bias_dps * DEG, rel=0.05)
    assert np.diagonal(m, axis1=1, axis2=2).std() == pytest.approx(spec.scale_factor_pct / 100,
                                                                   rel=0.05)
    assert m[:, 0, 1].std() == pytest.approx(np.radians(spec.misalignment_deg), rel=0.06)
    assert abs(on.mean()) < 4 * spec.turn_on_bias_dps * DEG / np.sqrt(on.size)


def test_scale_factor_bias_saturation_and_quantisation_are_applied():
    spec = GyroSpec(range_dps=300, noise_density_dps_rthz=0, bias_instability_dph=0,
                    turn_on_bias_dps=0.5, scale_factor_pct=1.0, misalignment_deg=0.5,
                    resolution_dps=0.1)
    rng = np.random.default_rng(5)
    x = np.zeros((5, 3))
    x[:, 0] = np.radians([0, 100, 200, 400, -500])
    y, sat, err = corrupt(x, spec, 100.0, rng)
    expect = x @ err.matrix.T + err.turn_on_bias
    expect = np.round(expect / (0.1 * DEG)) * 0.1 * DEG
    lim = np.radians(300)
    assert np.allclose(y, np.clip(expect, -lim, lim))
    assert list(sat) == [False, False, False, True, True]


def test_thermal_drift_and_g_sensitivity_add_slow_and_dynamic_bias():
    spec = GyroSpec(noise_density_dps_rthz=0, bias_instability_dph=0, turn_on_bias_dps=0,
                    scale_factor_pct=0, misalignment_deg=0, thermal_drift_dps_per_k=0.05,
                    g_sensitivity_dps_per_g=0.1)
    n = 1000
    temp = np.linspace(0, 10, n)
    force = np.zeros((n, 3))
    force[:, 2] = G0
    y, _, err = corrupt(np.zeros((n, 3)), spec, 100.0, np.random.default_rng(2),
                        temperature_delta=temp, specific_force=force)
    assert np.allclose(y, temp[:, None] * err.thermal + force @ err.g_sensitivity.T)
    assert np.abs(err.thermal).max() > 0


def test_grades_resolve_and_unknown_names_list_the_known_ones():
    assert get_grade("industrial").name == "xsens_mti3"
    tactical, consumer = get_grade("tactical").gyro, get_grade("consumer").gyro
    assert tactical.bias_instability_dph < consumer.bias_instability_dph
    with pytest.raises(ValueError, match="known grades: .*xsens_mti3"):
        get_grade("mems9000")


def test_gauss_markov_is_stationary_with_the_stated_sigma():
    x = gauss_markov(400000, 100.0, 2.0, 5.0, np.random.default_rng(1), axes=2)
    assert x.std() == pytest.approx(2.0, rel=0.08)
    lag = 500  # 5 s = one correlation time
    r = np.mean(x[lag:] * x[:-lag]) / x.var()
    assert r == pytest.approx(np.exp(-1), abs=0.08)


def test_the_error_conditions_give_the_specs_they_state():
    from firenav_framework.simulator.imu_grades import (IMU_ERRORS, STILL_START_RESIDUAL_DPS,
                                                        error_specs)
    grade = get_grade("microstrain_3dm_gx5_25")
    specs = {e: error_specs(grade, e) for e in IMU_ERRORS}
    assert specs["datasheet"][0] == grade.gyro and specs["datasheet"][1] == grade.accel
    worn_gyro, worn_accel, _ = specs["as_worn"]
    for key, value in grade.as_worn.gyro.items():
        assert getattr(worn_gyro, key) == value
    assert worn_accel.noise_density_ug_rthz == grade.as_worn.accel["noise_density_ug_rthz"]
    assert worn_gyro.vibration_bias_dps > 0 == grade.gyro.vibration_bias_dps
    cal = specs["calibrated"][0]
    assert cal.turn_on_bias_dps == STILL_START_RESIDUAL_DPS
    assert cal.vibration_bias_dps == worn_gyro.vibration_bias_dps   # not calibrated away
    # a scenario's own override sits on top, but a still start takes any turn-on bias
    over = error_specs(grade, "as_worn", gyro={"turn_on_bias_dps": 0.5})[0]
    assert over.turn_on_bias_dps == 0.5
    assert error_specs(grade, "calibrated", gyro={"turn_on_bias_dps": 0.5})[0] \
        .turn_on_bias_dps == STILL_START_RESIDUAL_DPS
    # ideal: the readings are the motion itself, to the last bit
    g, a, _ = specs["ideal"]
    x = np.random.default_rng(0).normal(0, 3.0, (500, 3))
    y, sat, _ = corrupt(x, g, 200.0, np.random.default_rng(1), specific_force=x * 20,
                        temperature_delta=np.linspace(0, 10, 500))
    assert np.array_equal(y, x) and not sat.any()
    with pytest.raises(ValueError, match="as_worn, calibrated, datasheet, ideal"):
        error_specs(grade, "factory")


def test_vibration_rectification_grows_with_the_square_root_of_the_vibration():
    from firenav_framework.simulator.imu_errors import vibration_rms
    spec = GyroSpec(noise_density_dps_rthz=0, bias_instability_dph=0, turn_on_bias_dps=0,
                    scale_factor_pct=0, misalignment_deg=0, vibration_bias_dps=0.4)
    fs, n = 200.0, 4000
    t = np.arange(n) / fs
    force = np.zeros((n, 3))
    force[:, 2] = G0                      # at rest: no bias at all
    y0, _, err = corrupt(np.zeros((n, 3)), spec, fs, np.random.default_rng(4),
                         specific_force=force)
    assert np.abs(y0).max() < 1e-9        # rad/s: only the rounding of a steady 1 g (numpy 2.4: 8e-11)
    for amp_g in (0.5, 2.0):              # 40 Hz vibration of rms amp_g / sqrt(2) [g]
        shaken = force.copy()
        shaken[:, 0] = amp_g * G0 * np.sin(2 * np.pi * 40.0 * t)
        assert np.median(vibration_rms(shaken, fs)) == pytest.approx(amp_g / np.sqrt(2),
                                                                     rel=0.02)
        y, _, err = corrupt(np.zeros((n, 3)), spec, fs, np.random.default_rng(4),
                            specific_force=shaken)
        mid = slice(n // 4, 3 * n // 4)
        np.testing.assert_allclose(y[mid].mean(axis=0),
                                   err.vibration * np.sqrt(amp_g / np.sqrt(2)), rtol=0.02)
    # the per-run direction of the bias is drawn with the stated spread per axis
    draws = np.array([draw_errors(spec, np.random.default_rng(i)).vibration for i in range(3000)])
    assert draws.std() == pytest.approx(0.4 * DEG, rel=0.05)


def test_as_worn_grades_at_rest_keep_their_datasheet_noise_and_bias_statistics():
    """Standing still (no vibration) an as-worn unit's gyro is its datasheet's: the Allan
    deviation of its noise and in-run bias and the spread of its turn-on bias."""
    from firenav_framework.simulator.imu_grades import error_specs
    grade = get_grade("xsens_mti3")
    spec = error_specs(grade, "as_worn")[0]
    spec = spec.model_copy(update={"turn_on_bias_dps": 0.0, "thermal_drift_dps_per_k": 0.0})
    fs, n = 100.0, int(3600 * 100)
    force = np.zeros((n, 3))
    force[:, 2] = G0
    y, _, _ = corrupt(np.zeros((n, 3)), spec, fs, np.random.default_rng(11), specific_force=force)
    y -= y.mean(axis=0)                   # g-sensitivity at 1 g: a constant
    used, adev = allan_deviation(y[:, 2], fs, np.array([0.1, 1.0, 10.0]))
    expected = allan_model(used, spec.noise_density_dps_rthz * DEG,
                           spec.bias_instability_dph * DEG / 3600, spec.bias_tau_s)
    np.testing.assert_allclose(adev, expected, rtol=0.15)
    on = np.array([draw_errors(error_specs(grade, "as_worn")[0],
                               np.random.default_rng(i)).turn_on_bias for i in range(2000)])
    assert on.std() == pytest.approx(grade.gyro.turn_on_bias_dps * DEG, rel=0.05)
