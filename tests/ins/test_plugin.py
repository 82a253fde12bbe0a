"""The zupt_ins plugin: ports, frames, and bad input that must not corrupt the state."""
from __future__ import annotations

import math

import numpy as np
import pytest
from pydantic import ValidationError

from firenav_framework import ImuBlock, Odometry, PoseEstimate
from firenav_framework.testing import check_plugin, make_component, run_component
from firenav_plugins.estimators.zupt_ins import ZuptInsEstimator, ZuptInsParams
from tests.contract.known import known

from .synthetic import Stride, add_noise, walk

WALK = add_noise(walk([Stride((0.7, 0.0, 0.0)), Stride((0.7, 0.2, 0.0), turn=0.3),
                       Stride((0.6, 0.3, 0.0)), Stride((0.5, 0.4, 0.0), turn=0.2)]),
                 np.random.default_rng(4))


def blocks(rec=WALK, size=40, agent="ff1", device="ff1/imu"):
    return [("imu", ImuBlock.from_arrays(rec.t[i:i + size], rec.accel[i:i + size],
                                         rec.gyro[i:i + size], agent=agent, device=device))
            for i in range(0, len(rec.t), size)]


def test_conforms_and_publishes_steps():
    rec = check_plugin(ZuptInsEstimator, {"outputs": {"state_rate": 10.0}}, sample_input=blocks(),
                       exclude=known("estimator", "zupt_ins"))
    odo = rec.on("odometry")
    steps = [m for m in odo if m.motion == "walk"]
    assert len(steps) == 4
    assert all(isinstance(m, Odometry) and m.agent == "ff1" and m.device == "ff1/imu" for m in odo)
    np.testing.assert_allclose(steps[0].delta, [0.7, 0.0, 0.0], atol=0.02)
    assert abs(steps[1].dheading - 0.3) < 0.01
    poses = rec.on("pose")
    assert len(poses) == len(odo) and all(isinstance(p, PoseEstimate) for p in poses)
    states = rec.on("state")
    assert 10 * (WALK.t[-1] - 0.5) < len(states) <= 10 * WALK.t[-1] + 1
    assert {d.code for d in rec.on("diagnostics")} >= {"imu_rate", "ins_aligned"}


def test_building_frame_from_initial_pose():
    h = math.radians(90)
    rec = run_component(ZuptInsEstimator, {"start": {"mode": "pose", "position": (10.0, 5.0, 3.0),
                                                      "heading": h}}, blocks())
    ins = rec.on("odometry")[-1]
    pose = rec.on("pose")[-1]
    expected = np.array([10.0 - ins.position[1], 5.0 + ins.position[0], 3.0 + ins.position[2]])
    np.testing.assert_allclose(pose.position, expected, atol=1e-12)
    assert abs(pose.heading - (ins.heading + h)) < 1e-12
    assert pose.frame == "building"
    unplaced = run_component(ZuptInsEstimator, {}, blocks()).on("pose")[-1]
    assert unplaced.frame == "odometry"          # not placed in the building: its own frame
    np.testing.assert_allclose(unplaced.position, ins.position, atol=1e-12)
    # the covariance turns with the frame: x variance becomes y variance
    odo_cov = np.diag([1.0, 2.0, 3.0, 4.0])
    comp = make_component(ZuptInsEstimator, {"start": {"mode": "pose", "position": (0, 0, 0),
                                                       "heading": "90 deg"}})[0]
    _, _, cov = comp.placement("ff1").apply(np.zeros(3), 0.0, odo_cov)
    np.testing.assert_allclose(np.diag(cov), [2.0, 1.0, 3.0, 4.0], atol=1e-12)


def _poisoned(bad: ImuBlock, at: int = 30):
    good = blocks()
    return good[:at] + [("imu", bad)] + good[at:]


def _same_output(a, b):
    for port in ("odometry", "pose"):
        assert [m.digest() for m in a.on(port)] == [m.digest() for m in b.on(port)], port


def _with_nan_sample(index: int = 20, sample: int = 3):
    msgs = blocks()
    stream, blk = msgs[index]
    acc = blk.accel.copy()
    acc[sample] = np.nan
    msgs[index] = (stream, ImuBlock.from_arrays(blk.time, acc, blk.gyro, agent="ff1",
                                                device="ff1/imu"))
    return msgs


def test_a_block_breaking_the_input_contract_is_counted_and_changes_nothing():
    """The estimator's input is a sensor plugin's output (finite samples, increasing time):
    a block that is not is skipped whole, counted and reported, never integrated."""
    clean = run_component(ZuptInsEstimator, {}, blocks())
    t = np.full(5, np.nan)
    nan_time = ImuBlock(t=1.0, time=t, accel=np.zeros((5, 3)), gyro=np.zeros((5, 3)),
                        agent="ff1", device="ff1/imu")
    _, old = blocks()[10]   # a block from the past arrives again, late
    for bad, count, code in ((nan_time, "rejected_blocks_nonfinite", "imu_nonfinite"),
                             (old, "rejected_blocks_time_order", "imu_time_backwards")):
        comp, rec, stats = make_component(ZuptInsEstimator, {})
        for stream, msg in _poisoned(bad):
            comp.handle(stream, msg)
        comp.finish()
        _same_output(clean, rec)
        assert stats.counts["under_test"][count] == 1
        assert [d.code for d in rec.on("diagnostics")].count(code) == 1


def test_a_block_with_one_nan_sample_is_skipped_and_the_walk_still_tracked():
    comp, rec, stats = make_component(ZuptInsEstimator, {})
    for s, m in _with_nan_sample():
        comp.handle(s, m)
    comp.finish()
    assert stats.counts["under_test"]["rejected_blocks_nonfinite"] == 1
    steps = [m for m in rec.on("odometry") if m.motion != "still"]
    assert len(steps) == 4
    # four strides of 0.7 m; the skipped 0.2 s of one swing cannot be integrated
    assert 2.1 < sum(math.hypot(*m.delta[:2]) for m in steps) < 2.9


def test_behind_a_foot_imu_sensor_only_the_bad_sample_is_lost():
    """The screening is the sensor's: through foot_imu the NaN sample is dropped there, and
    the INS integrates every other sample of the block."""
    from firenav_plugins.sensors.foot_imu import FootImuSensor
    sensor, sensed, sensor_stats = make_component(FootImuSensor, {}, cid="imu")
    for s, m in _with_nan_sample():
        sensor.handle(s, m)
    sensor.finish()
    assert sensor_stats.counts["imu"]["nonfinite_samples"] == 1
    comp, rec, stats = make_component(ZuptInsEstimator, {})
    for blk in sensed.on("imu"):
        comp.handle("imu", blk)
    comp.finish()
    assert not any(k.startswith("rejected_blocks") for k in stats.counts.get("under_test", {}))
    assert sum(len(b) for b in sensed.on("imu")) == len(WALK.t) - 1
    assert len([m for m in rec.on("odometry") if m.motion == "walk"]) == 4


def test_raw_device_frame_is_refused():
    _, blk = blocks()[0]
    raw = ImuBlock.from_arrays(blk.time, blk.accel, blk.gyro, agent="ff1", device="ff1/imu",
                               frame="device")
    comp, rec, stats = make_component(ZuptInsEstimator, {})
    comp.handle("imu", raw)
    comp.handle("imu", raw.shifted(0.2))
    assert stats.counts["under_test"]["rejected_blocks_not_flu"] == 2
    # reported once (rate-limited), counted every time
    assert [d.code for d in rec.on("diagnostics")] == ["imu_not_flu"]


def test_gap_is_counted_and_bounded():
    msgs = blocks()
    shifted = [(s, m.shifted(5.0)) if m.t > WALK.t[400] else (s, m) for s, m in msgs]
    comp, rec, stats = make_component(ZuptInsEstimator, {})
    for s, m in shifted:
        comp.handle(s, m)
    comp.finish()
    assert stats.counts["under_test"]["gaps"] == 1
    assert any(d.code == "imu_gap" for d in rec.on("diagnostics"))
    # the gap falls in a stance: integrated as 0.1 s at rest, the track is unharmed
    last = rec.on("odometry")[-1]
    np.testing.assert_allclose(last.position, WALK.footprints[-1], atol=0.05)


def test_two_feet_of_one_agent_get_their_own_filters():
    left = blocks(device="ff1/left")
    right = blocks(device="ff1/right")
    rec = run_component(ZuptInsEstimator, {}, [m for pair in zip(left, right) for m in pair])
    by_dev = {d: [m for m in rec.on("odometry") if m.device == d and m.motion == "walk"]
              for d in ("ff1/left", "ff1/right")}
    assert len(by_dev["ff1/left"]) == len(by_dev["ff1/right"]) == 4
    np.testing.assert_allclose(by_dev["ff1/left"][-1].position, by_dev["ff1/right"][-1].position)


def test_reset_forgets_the_agent():
    comp, rec, _ = make_component(ZuptInsEstimator, {})
    for s, m in blocks()[:60]:
        comp.handle(s, m)
    comp.reset("ff1")
    assert "ff1" not in comp.state


@pytest.mark.parametrize("bad", [{"zaru": {"enabled": True}}, {"detector": {"low": 9.0}},
                                 {"detector": {"kind": "lstm"}}, {"gravity": {"magnitude": 1.0}},
                                 {"start": {"mode": "entrance"}},
                                 {"start": {"mode": "unknown", "heading": 0.0}}])
def test_inconsistent_parameters_are_refused(bad):
    with pytest.raises(ValidationError):
        ZuptInsParams(**bad)


def _biased_walk(start_rest: float, gyro_bias):
    rec = add_noise(walk([Stride((0.7, 0.0, 0.0))] * 6, start_rest=start_rest),
                    np.random.default_rng(9))
    rec.gyro[:] += np.asarray(gyro_bias)
    return rec


def test_still_start_with_an_uncalibrated_gyro_gives_its_bias():
    """A consumer gyro reading 9 deg/s at rest never looks still to the ZUPT detector; the
    promised still start is judged from signal variance, so the bias is still measured."""
    bias = (0.15, -0.06, 0.08)  # rad/s
    rec = _biased_walk(6.0, bias)
    comp, out, _ = make_component(ZuptInsEstimator, {"alignment": {"gyro_bias": True, "duration": 5.0}})
    for stream, msg in blocks(rec):
        comp.handle(stream, msg)
    comp.finish()
    (aligned,) = [d for d in out.on("diagnostics") if d.code == "ins_aligned"]
    assert aligned.level == "info" and 5.0 <= aligned.t <= 6.0
    engine = comp.state["ff1"]["ff1/imu"].engine
    np.testing.assert_allclose(engine.nominal[13:16], bias, atol=2e-3)   # bg in x[13:16]
    steps = [m for m in out.on("odometry") if m.motion == "walk"]
    assert len(steps) == 6


def test_a_shorter_still_period_than_asked_is_used_and_reported():
    rec = add_noise(walk([Stride((0.7, 0.0, 0.0))] * 4, start_rest=2.0), np.random.default_rng(2))
    out = run_component(ZuptInsEstimator, {"alignment": {"duration": 5.0}}, blocks(rec))
    (aligned,) = [d for d in out.on("diagnostics") if d.code == "ins_aligned"]
    assert aligned.level == "warning" and "still period of 2.0" in aligned.text
    assert abs(aligned.t - 2.0) < 0.1
    assert len([m for m in out.on("odometry") if m.motion == "walk"]) == 4


@pytest.mark.parametrize("yaw_bias_dps, options, warned", [
    (0.3, {}, True), (-0.3, {}, True), (0.0, {}, False), (0.05, {}, False),
    (0.3, {"alignment": {"gyro_bias": True, "duration": 5.0}}, False),
    (0.3, {"filter": {"bias_states": True}, "zaru": {"enabled": True}}, False)])
def test_a_heading_that_turns_while_the_foot_lies_still_is_reported(yaw_bias_dps, options,
                                                                    warned):
    """The foot is still (and flat) for 6 s; the vertical gyro reads the bias alone. The
    warning says the turn rate the still periods showed; a calibrated or estimated bias,
    or one below 0.1 deg/s, is not reported."""
    rec = _biased_walk(6.0, (0.0, 0.0, math.radians(yaw_bias_dps)))
    out = run_component(ZuptInsEstimator, options, blocks(rec))
    found = [d for d in out.on("diagnostics") if d.code == "ins_gyro_uncalibrated"]
    assert bool(found) == warned
    if warned:
        (d,) = found
        rate = float(d.text.split("turned by ")[1].split(" deg/s")[0])
        assert rate == pytest.approx(abs(yaw_bias_dps), abs=0.02)
        assert "bias_states: true" in d.text and "gyro_bias" not in d.text


def test_gyro_noise_at_rest_is_not_taken_for_a_bias():
    """A noisy consumer gyro (0.1 deg/s/rtHz): over a 0.1 s still start its mean wanders
    by ~0.3 deg/s; over the 5 s of still periods the judgement waits for, by ~0.04."""
    rng = np.random.default_rng(3)
    warned = 0
    for _ in range(10):
        rec = _biased_walk(6.0, (0.0, 0.0, 0.0))
        rec.gyro[:] += rng.normal(0.0, math.radians(0.1) * math.sqrt(200.0), rec.gyro.shape)
        out = run_component(ZuptInsEstimator, {"imu": {"gyro_noise_density": math.radians(0.1),
                                              "sample_rate": 200.0}}, blocks(rec))
        warned += any(d.code == "ins_gyro_uncalibrated" for d in out.on("diagnostics"))
    assert warned == 0
