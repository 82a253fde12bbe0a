"""Eq. 3: door-crossing heading, its 180 degree ambiguity and the adaptive covariance."""
from __future__ import annotations

import math

import numpy as np
import pytest

from firenav_framework.building import bundled_plan, load_building
from firenav_framework.testing import make_component
from firenav_plugins.estimators.pdr_ekf import PdrEkfEstimator
from firenav_plugins.estimators.pdr_ekf.door_heading import (DoorHeadingConfig, HeadingWindow,
                                                              door_heading_measurement)
from firenav_framework.geometry import wrap_angle

from .synth import closest_passes, detections, feed, odometry, walk

DEG = math.pi / 180
CFG = DoorHeadingConfig()


@pytest.fixture(scope="module")
def building():
    return load_building(bundled_plan("three_storey"))


def window(door_heading: float, walking: list[float], ambiguous: bool = True) -> HeadingWindow:
    w = HeadingWindow("d", door_heading, ambiguous, 0.0, walked=CFG.clear_distance)
    for a in walking:
        w.add(np.array([math.cos(a), math.sin(a)]), CFG)
    return w


def test_known_bias_is_measured():
    """MEMS walks 12 deg off the door axis: eq. 3 gives dtheta = +12 deg... of correction."""
    bias = 12 * DEG
    m = door_heading_measurement(window(90 * DEG, [90 * DEG - bias] * 3), 0.0, CFG)
    assert m.accepted
    assert m.z == pytest.approx(bias)
    assert m.crossing == pytest.approx(90 * DEG)
    assert m.var == pytest.approx(CFG.sigma ** 2 * math.exp((bias / CFG.discrepancy_scale) ** 2))


@pytest.mark.parametrize("true_crossing", [90 * DEG, -90 * DEG])
@pytest.mark.parametrize("bias", [25 * DEG, -25 * DEG])
def test_180_degree_ambiguity_resolved_both_directions(true_crossing, bias):
    """The door axis is +90 deg; walking through it either way with a biased MEMS heading,
    the crossing direction nearest the MEMS walking direction is taken, and eq. 3 gives
    the bias both ways."""
    mems = [true_crossing - bias + d for d in (-3 * DEG, 0.0, 3 * DEG)]
    m = door_heading_measurement(window(90 * DEG, mems), 0.0, CFG)
    assert wrap_angle(m.crossing - true_crossing) == pytest.approx(0.0, abs=1e-9)
    assert m.z == pytest.approx(bias, abs=1e-6)


def test_ambiguity_uses_the_heading_history():
    """A 120 deg MEMS error alone would pick the wrong crossing; with the perturbation the
    filter already estimated (history), the right one is chosen."""
    true_crossing, bias = -90 * DEG, 120 * DEG
    mems = [true_crossing - bias] * 3
    wrong = door_heading_measurement(window(90 * DEG, mems), 0.0, CFG)
    assert wrap_angle(wrong.crossing - true_crossing) == pytest.approx(math.pi)
    right = door_heading_measurement(window(90 * DEG, mems), 115 * DEG, CFG)
    assert wrap_angle(right.crossing - true_crossing) == pytest.approx(0.0, abs=1e-9)
    assert right.z == pytest.approx(bias)


def test_entrance_has_no_ambiguity():
    m = door_heading_measurement(window(90 * DEG, [-80 * DEG] * 3, ambiguous=False), 0.0, CFG)
    assert m.crossing == pytest.approx(90 * DEG) and not m.accepted


def test_covariance_grows_with_the_discrepancy_and_large_ones_are_refused():
    """A turn right after the door: the larger the discrepancy, the weaker the update;
    beyond the limit (45 deg) none at all."""
    vs = []
    for d in (0, 10, 20, 30, 40):
        m = door_heading_measurement(window(0.0, [d * DEG] * 3), 0.0, CFG)
        assert m.accepted
        vs.append(m.var)
    assert all(b > a for a, b in zip(vs, vs[1:]))
    assert vs[-1] / vs[0] > 500
    turned = door_heading_measurement(window(0.0, [-60 * DEG] * 3), 0.0, CFG)
    assert not turned.accepted


def test_spread_of_the_strides_weakens_the_update():
    straight = door_heading_measurement(window(0.0, [0.0] * 3), 0.0, CFG)
    wobbly = door_heading_measurement(window(0.0, [-20 * DEG, 0.0, 20 * DEG]), 0.0, CFG)
    assert wobbly.z == pytest.approx(0.0, abs=1e-9)
    assert wobbly.var > 1.5 * straight.var


def test_the_window_skips_the_door_itself():
    """Strides starting less than clear_distance (1 m) past the tag are not averaged."""
    w = HeadingWindow("d", 0.0, True, 0.0)
    assert not w.add(np.array([0.0, 0.8]), CFG)    # opening the door: sideways, not used
    done = [w.add(np.array([1.3, 0.0]), CFG) for _ in range(4)]
    assert done == [False, False, False, True]      # the stride from 0.8 m is not used either
    assert w.directions == [0.0, 0.0, 0.0]


def test_door_update_removes_a_known_heading_bias(building):
    """End to end: the start heading is 12 deg off, so every MEMS stride is 12 deg off.
    Walking north through door d0_n3 (surveyed tag), the door heading update estimates
    dtheta = -12 deg and the track after the door walks straight north."""
    bias = 12 * DEG
    w = walk([(16.5, 6.75), (16.5, 13.5)], stride=0.9)
    odo = odometry(w, yaw=0.7)
    start_heading = math.pi / 2 + bias         # a wrongly measured start heading
    ekf, rec, stats = make_component(PdrEkfEstimator, {
        "start": {"mode": "pose", "position": (16.5, 6.75, 0.0), "heading": start_heading,
                  "sigma_heading": 20 * DEG}, "rfid": {"surveyed": {"T1": "d0_n3"}}},
        building=building)
    ekf.start()
    passes = closest_passes(w, {"d0_n3": (16.5, 8.0)})
    feed(ekf, odo + detections(passes, {"d0_n3": "T1"}))
    counts = stats.counts["under_test"]
    assert counts["door_headings"] == 1
    dtheta = ekf.state["ff1"].filt.x[4]
    assert dtheta == pytest.approx(-bias, abs=1.5 * DEG)
    final = rec.on("pose")[-1]
    assert final.heading == pytest.approx(math.pi / 2, abs=2 * DEG)
    door = [d for d in rec.on("diagnostics") if d.code == "door_heading"]
    assert "d0_n3" in door[0].text
