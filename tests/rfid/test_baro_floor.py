"""pdr_ekf's floor with the simulator's barometers, consumer IMU, no stair map.

The bundled zupt_multifloor walk cut at 330 s (floor 0 -> 1 -> 2), every foot IMU of the
consumer grade (``imu_grade``), tuning seeds: the simulator's barometers (weather,
stack effect, door openings, device offset, drift, noise: simulator/barometer.py) through
the ``barometer`` sensor with its defaults, against the simulator's truth, counted as
``firenav evaluate`` counts the floor. Bad pressure lines (NaN, a stuck sensor, a 50 hPa
jump) are put into the same run's lines.
"""
from __future__ import annotations

import numpy as np
import pytest

from firenav_framework.codecs.baro_lines import BaroLinesCodec, BaroReading
from firenav_framework.messages import RawFrame
from firenav_framework.simulator import simulate
from firenav_framework.testing import make_component
from firenav_framework.simulator.scenario import load_scenario
from firenav_plugins.estimators.pdr_ekf import PdrEkfEstimator
from firenav_plugins.sensors.barometer import BarometerSensor

from .simulated import simulated_inputs
from .synth import feed

SCENARIO, DURATION = "zupt_multifloor", 330.0
NO_MAP = {"height": {"stair_zone": None}}


def floors(odo, heights, building):
    ekf, rec, stats = make_component(PdrEkfEstimator, NO_MAP, building=building)
    ekf.start()
    feed(ekf, odo + heights)
    return rec.on("pose"), stats.counts.get("under_test", {}), rec


def right(poses, truth, building) -> np.ndarray:
    from benchmarks.bench_rfid_baro import floors_right
    return floors_right(poses, truth, building)


@pytest.fixture(scope="module")
def runs():
    return {seed: simulated_inputs(SCENARIO, seed, imu_grade="consumer", duration=DURATION)
            for seed in (100, 101)}


def test_the_barometer_keeps_the_floor_that_counted_stairs_lose(runs):
    with_b, without = [], []
    for seed, (odo, heights, truth, building) in runs.items():
        assert heights, "the bundled scenario carries a barometer"
        poses, counts, _ = floors(odo, heights, building)
        # every height once the filter has placed the start (at its first pose)
        after = sum(h.t >= poses[0].t for h in heights)
        assert after - 2 <= counts["pressure_heights"] <= after + 2
        with_b.append(right(poses, truth["ff1"], building))
        without.append(right(floors(odo, [], building)[0], truth["ff1"], building))
    assert np.mean(np.concatenate(with_b)) >= 0.995
    assert all(r.mean() >= 0.99 for r in with_b)
    # measurably worse without: at least one storey of the walk on the wrong floor
    assert np.mean(np.concatenate(without)) <= 0.9
    assert np.mean(np.concatenate(with_b)) - np.mean(np.concatenate(without)) >= 0.1


def _corrupt(frames: list[RawFrame], t_end: float):
    """ff1's lines with a NaN line every 10 s, a stuck sensor for 20 s from 60 s (the
    wearer on the ground floor) and the offset jumping by 50 hPa from 150 s on (it stays:
    a sensor reset), as the same serial link carries them."""
    codec = BaroLinesCodec()
    out, n_nan, stuck_at = [], 0, None
    for f in frames:
        r = codec.decode(f)[0]
        if r.device != "ff1/baro":
            out.append(f)
            continue
        p = r.pressure
        if 60.0 <= r.t < 80.0:
            stuck_at = p if stuck_at is None else stuck_at
            p = stuck_at
        if r.t >= 150.0:
            p += 5000.0
        enc = codec.encode([BaroReading(r.t, r.device, p)])[0]
        out.append(RawFrame(t=f.t, agent=f.agent, device=f.device, transport=f.transport,
                            channel=enc.channel, data=enc.data))
        if int(r.t * 10) % 100 == 0:
            n_nan += 1
            out.append(RawFrame(t=f.t, agent=f.agent, device=f.device,
                                transport=f.transport, channel="",
                                data=b"BARO,ff1/baro,nan"))
    return out, n_nan


def test_bad_pressure_lines_are_counted_logged_skips_that_keep_the_floor(runs):
    odo, clean, truth, building = runs[100]
    sim = simulate(load_scenario(SCENARIO), 100, duration_s=DURATION, imu_grade="consumer")
    frames, n_nan = _corrupt(sim.messages["baro"], sim.t_end)
    assert n_nan > 20
    baro, rec, stats = make_component(BarometerSensor, {}, building=building)
    baro.start()
    feed(baro, frames)
    counts = stats.counts.get("under_test", {})
    heights = rec.on("height")
    assert counts["bad_frames"] == n_nan
    assert counts["stuck_readings"] > 0
    assert counts["jump_readings"] > 0
    assert counts["offset_jumps"] == 1
    codes = {d.code for d in rec.on("diagnostics")}
    assert {"baro_bad_line", "baro_stuck", "baro_jump", "baro_offset_jump"} <= codes
    # the heights after the jump carry on: no 400 m step
    h = np.array([m.height for m in heights])
    assert np.all(np.abs(np.diff(h)) < 3.0)
    poses, _, _ = floors(odo, heights, building)
    good, _, _ = floors(odo, clean, building)
    fl, fl_clean = np.array([p.floor for p in poses]), np.array([p.floor for p in good])
    assert len(fl) == len(fl_clean)
    assert np.mean(fl == fl_clean) >= 0.995
    assert right(poses, truth["ff1"], building).mean() >= 0.99


def test_nan_heights_are_counted_and_logged_by_the_filter(runs):
    import dataclasses
    odo, heights, truth, building = runs[101]
    bad = [dataclasses.replace(h, height=float("nan")) for h in heights[100:140]]
    poses, counts, rec = floors(odo, heights[:100] + bad + heights[140:], building)
    good, _, _ = floors(odo, heights, building)
    assert counts["bad_pressure_heights"] == 40
    assert any(d.code == "bad_pressure_height" for d in rec.on("diagnostics"))
    same = np.mean(np.array([p.floor for p in poses]) == np.array([p.floor for p in good]))
    assert same >= 0.995
