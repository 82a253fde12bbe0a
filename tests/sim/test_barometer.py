"""The simulated barometers against their stated parameters and independent physics.

Independent expectations: the ISA table (101 325 Pa at sea level, 22 632 Pa at the
11 km tropopause, 89 875 Pa at 1000 m), the building-science stack-effect constant
(3460 Pa K / m, e.g. ASHRAE Fundamentals), the statistics of white noise, uniform
quantisation (variance q^2 / 12), uniform offsets (variance a^2 / 3), random walks
(variance sigma^2 t) and Poisson counts.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from firenav_framework.codecs.baro_lines import BaroLinesCodec
from firenav_framework.simulator import simulate
from firenav_framework.simulator.barometer import (BaroSpec, Walk, draw_air, draw_interior,
                                                   isa_pressure, read_barometer, worn_height)
from firenav_framework.simulator.output import write_simulation
from firenav_framework.simulator.scenario import (SCENARIO_DIR, BarometerConfig, Pressure,
                                                  load_scenario_text)


def test_isa_pressure_matches_the_standard_atmosphere_table():
    assert isa_pressure(0.0) == pytest.approx(101_325.0)
    assert isa_pressure(1000.0) == pytest.approx(89_875.0, abs=2.0)
    assert isa_pressure(11_000.0) == pytest.approx(22_632.0, rel=1e-3)
    # near the ground one metre is about 12 Pa (rho g = 1.225 * 9.81)
    assert isa_pressure(0.0) - isa_pressure(1.0) == pytest.approx(12.01, abs=0.05)


def test_device_noise_quantisation_and_offset_are_the_datasheet_figures():
    spec = BarometerConfig().spec()                # ms5611: 1.2 Pa rms, 1 Pa steps
    rng = np.random.default_rng(1)
    t = np.arange(0.0, 600.0, 0.1)
    true = np.full(len(t), 100_000.0)
    still = BaroSpec(**{**spec.__dict__, "drift_pa_per_sqrt_s": 0.0})
    tr, p, offset = read_barometer(t, true, still, rng)
    assert np.allclose(tr - t, spec.latency_s)
    assert np.allclose(p, np.round(p))                       # whole pascals
    assert abs(offset) <= spec.offset_pa
    assert p.mean() - true[0] == pytest.approx(offset, abs=0.1)
    expected = np.sqrt(spec.noise_pa ** 2 + spec.resolution_pa ** 2 / 12)
    assert p.std() == pytest.approx(expected, rel=0.05)
    offsets = [read_barometer(t[:2], true[:2], still, rng)[2] for _ in range(4000)]
    assert np.std(offsets) == pytest.approx(spec.offset_pa / np.sqrt(3), rel=0.05)


def test_device_drift_is_a_random_walk_of_the_stated_rate():
    spec = BaroSpec(noise_pa=0.0, resolution_pa=0.0, offset_pa=0.0, drift_pa_per_sqrt_s=0.2,
                    latency_s=0.0, max_rate_hz=50.0)
    rng = np.random.default_rng(2)
    t = np.arange(0.0, 400.0, 0.5)
    ends = np.array([read_barometer(t, np.zeros(len(t)), spec, rng)[1][-1]
                     for _ in range(1500)])
    assert ends.var() == pytest.approx(0.2 ** 2 * t[-1], rel=0.1)


def test_the_weather_walk_is_shared_and_of_the_stated_rate():
    ends = np.array([Walk(0.05, 1200.0, np.random.default_rng(k))(np.array([1200.0]))[0]
                     for k in range(1500)])
    assert ends.var() == pytest.approx(0.05 ** 2 * 1200.0, rel=0.1)
    w = Walk(0.05, 100.0, np.random.default_rng(0))
    assert w(np.array([0.0]))[0] == 0.0
    assert np.allclose(w(np.array([10.0, 50.0])), w(np.array([10.0, 50.0])))


def test_building_pressure_stack_effect_and_door_openings():
    cfg = Pressure(outside_c=(0.0, 0.0), inside_c=20.0, door_rate_per_min=2.0,
                   door_step_pa=4.0, floor_sigma_pa=0.0)
    rng = np.random.default_rng(3)
    air = draw_air(cfg, rng)
    assert air.t_out == pytest.approx(273.15)
    assert 99_000 <= air.p0 <= 103_000
    inside = draw_interior(cfg, air, 3, (0.0, 10.5), 36_000.0, [], rng)
    assert inside.stack == pytest.approx(3460.0 * (1 / 273.15 - 1 / 293.15), rel=0.01)
    assert 0.3 * 10.5 <= inside.neutral_z <= 0.7 * 10.5
    n = len(inside.doors)
    assert abs(n - 1200) < 4 * np.sqrt(1200)           # Poisson: 2/min over 10 h
    assert inside.doors[:, 2].std() == pytest.approx(4.0, rel=0.1)
    assert inside.doors[:, 1].mean() - inside.doors[:, 0].mean() == pytest.approx(30.0, rel=0.1)
    # warm inside, cold outside: higher inside than outside above the neutral plane
    t = np.zeros(2)
    off = inside.offset(t, np.array([inside.neutral_z, inside.neutral_z + 3.0]),
                        np.array([1, 1]), np.zeros((2, 2)), np.zeros(2))
    assert off[1] - off[0] == pytest.approx(3.0 * inside.stack)
    assert off[1] > off[0]


def test_a_crawling_wearer_carries_the_barometer_lower():
    h = worn_height(np.array(["walk", "crawl", "posture", "stairs_up"], dtype=object), 1.3)
    assert h[0] == h[3] == 1.3
    assert h[1] < 0.6 < h[2] < 1.3


def _scenario(duration: float = 240.0, **pressure):
    """zupt_multifloor (its first storey climb within ~4 min) as bundled, with its
    barometers."""
    path = SCENARIO_DIR / "zupt_multifloor.yaml"
    doc = yaml.safe_load(path.read_text())
    doc["duration_s"] = duration
    if pressure:
        doc.setdefault("environment", {})["pressure"] = pressure
    return load_scenario_text(yaml.safe_dump(doc), base_dir=path.parent)


def test_bundled_multifloor_scenarios_carry_barometers():
    from firenav_framework.simulator import load_scenario
    from firenav_framework.sources.simulator import scenario_ports
    for name in ("zupt_multifloor", "field_multifloor_long", "field_apartments", "incident"):
        sc = load_scenario(name)
        assert "baro" in scenario_ports(sc)
        assert any(a.sensors.barometer is not None for a in sc.model.agents)


def test_simulated_barometer_lines_follow_the_true_height():
    r = simulate(_scenario(), 5)
    frames, truth = r.messages["baro"], r.extra["baro"]
    assert len(frames) == len(truth)
    codec = BaroLinesCodec()
    rd = [codec.decode(f)[0] for f in frames]
    assert all(f.t == x.t for f, x in zip(frames, rd))
    worn = [i for i, x in enumerate(rd) if x.device == "ff1/baro"]
    ref = [i for i, x in enumerate(rd) if x.device == "base/baro"]
    assert len(worn) == pytest.approx(r.t_end * 10, abs=2)     # 10 Hz
    assert len(ref) == pytest.approx(r.t_end * 1, abs=2)       # the reference at 1 Hz
    assert all(rd[i].temperature is not None for i in ref)
    assert all(rd[i].temperature is None for i in worn)
    p = np.array([rd[i].pressure for i in worn])
    true = np.array([truth[i]["true_pa"] for i in worn])
    z = np.array([truth[i]["z"] for i in worn])
    err = p - true
    assert abs(np.median(err)) <= 150.0 + 5.0                   # the device's offset
    # white noise: the reading-to-reading difference less the true one
    d = np.diff(err)
    assert d.std() / np.sqrt(2) == pytest.approx(np.sqrt(1.2 ** 2 + 1 / 12), rel=0.1)
    # the pressure follows the barometer's true height (ISA, about 12 Pa per metre)
    tt = np.array([frames[i].t for i in worn])
    body = np.interp(tt - 0.02, r.truth["ff1"].t, r.truth["ff1"].position[:, 2])
    assert np.allclose(z[z > 1.0], body[z > 1.0] + 1.3, atol=0.05)
    up = z > 3.0
    assert up.any() and (~up).any()
    slope = np.polyfit(z, p, 1)[0]
    assert slope == pytest.approx(-12.0, rel=0.15)


def test_barometers_are_deterministic_and_leave_the_imu_alone():
    a, b = simulate(_scenario(60.0), 7), simulate(_scenario(60.0), 7)
    assert [f.data for f in a.messages["baro"]] == [f.data for f in b.messages["baro"]]
    path = SCENARIO_DIR / "zupt_multifloor.yaml"
    doc = yaml.safe_load(path.read_text())
    doc["duration_s"] = 60.0
    for ag in doc["agents"]:
        ag["sensors"].pop("barometer")
    plain = simulate(load_scenario_text(yaml.safe_dump(doc), base_dir=path.parent), 7)
    assert "baro" not in plain.messages
    assert np.array_equal(plain.imu["ff1"].accel, a.imu["ff1"].accel)


def test_barometer_lines_round_trip_through_the_simulation_folder(tmp_path: Path):
    import json

    from firenav_framework.sources.readers.sim_streams import parse_record
    r = simulate(_scenario(20.0), 1)
    write_simulation(r, tmp_path)
    recs = [json.loads(ln) for ln in (tmp_path / "streams.jsonl").read_text().splitlines()[1:]]
    baro = [parse_record(x) for x in recs if x["type"] == "raw_frame"]
    assert [m.data for _, m in baro] == [f.data for f in r.messages["baro"]]
    assert {port for port, _ in baro} == {"baro"}
    assert all("true_pa" in x["truth"] for x in recs if x["type"] == "raw_frame")


def test_a_barometer_faster_than_its_part_is_refused():
    with pytest.raises(ValueError, match="above the ms5611"):
        BarometerConfig(rate_hz=200.0)
    with pytest.raises(ValueError, match="unknown barometer model"):
        BarometerConfig(model="nope")


def test_an_imu_grade_variant_changes_the_imus_and_nothing_else():
    base, consumer = simulate(_scenario(20.0), 4), simulate(_scenario(20.0), 4,
                                                           imu_grade="consumer")
    assert consumer.imu["ff1"].grade == "consumer" and base.imu["ff1"].grade == "xsens_mtw"
    assert not np.allclose(consumer.imu["ff1"].gyro, base.imu["ff1"].gyro)
    assert [f.data for f in consumer.messages["baro"]] == [f.data for f in base.messages["baro"]]
    assert np.array_equal(consumer.truth["ff1"].position, base.truth["ff1"].position)
