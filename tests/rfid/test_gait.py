"""Gait classes and counted stairs: a climb and a backward descent of the stairwell."""
from __future__ import annotations

import math

import numpy as np
import pytest

from firenav_framework.building import bundled_plan, load_building
from firenav_framework.testing import make_component
from firenav_plugins.estimators.pdr_ekf import PdrEkfEstimator
from firenav_plugins.estimators.pdr_ekf.gait import GaitClassifier, count_stairs
from firenav_plugins.estimators.pdr_ekf.height import snap_levels

from .synth import feed, join, odometry, walk

RISE = 0.175          # stair01 of three_storey: 3.5 m in 20 steps


@pytest.fixture(scope="module")
def building():
    return load_building(bundled_plan("three_storey"))


def stairwell_round_trip() -> tuple:
    """Up stair01 (U-shaped, landing half way) to floor 1 forwards, back down backwards."""
    up = join(
        walk([(4.5, 6.75, 0.0), (1.4, 6.9, 0.0), (1.4, 8.0, 0.0)], stride=1.0),
        walk([(1.4, 8.0, 0.0), (1.4, 12.6, 1.75)], stride=0.92),          # flight 1: 5 strides
        walk([(1.4, 12.6, 1.75), (4.1, 12.6, 1.75)], stride=0.9),         # landing
        walk([(4.1, 12.6, 1.75), (4.1, 8.0, 3.5)], stride=0.92),          # flight 2
        walk([(4.1, 8.0, 3.5), (4.1, 7.0, 3.5), (4.9, 6.75, 3.5)], stride=0.9), pause=0.5)
    down = join(
        walk([(4.9, 6.75, 3.5), (4.1, 7.0, 3.5), (4.1, 8.0, 3.5)], stride=0.9),
        walk([(4.1, 8.0, 3.5), (4.1, 12.6, 1.75)], stride=0.92, backwards=True),
        walk([(4.1, 12.6, 1.75), (1.4, 12.6, 1.75)], stride=0.9),
        walk([(1.4, 12.6, 1.75), (1.4, 8.0, 0.0)], stride=0.92, backwards=True),
        walk([(1.4, 8.0, 0.0), (1.4, 6.9, 0.0), (4.5, 6.75, 0.0)], stride=1.0))
    return up, join(up, down, pause=2.0)


def run(building, w, dz_noise=0.03, labels=False, **params):
    odo = odometry(w, yaw=0.4, dz_noise=dz_noise, gradient=(0.05, -0.03), labels=labels,
                   rng=np.random.default_rng(3))
    ekf, rec, stats = make_component(PdrEkfEstimator, {
        "start": {"mode": "pose", "position": (4.5, 6.75, 0.0),
                  "heading": math.atan2(0.15, -3.1)}, **params}, building=building)
    ekf.start()
    feed(ekf, odo)
    return rec.on("pose"), stats.counts["under_test"]


def test_count_stairs_rounds_and_caps():
    assert count_stairs(0.35, 0.175) == 2
    assert count_stairs(-0.15, 0.175) == -1
    assert count_stairs(0.05, 0.2) == 1            # a stair stride is at least one stair
    assert count_stairs(0.61, 0.175) == 2          # at most two per stride of one foot
    assert count_stairs(0.61, 0.175, max_per_stride=4) == 3


def test_climb_and_backward_descent_give_the_right_floors(building):
    up, w = stairwell_round_trip()
    poses, counts = run(building, w)
    top = [p for p in poses if p.t <= up.t[-1]][-1]
    assert top.floor == 1 and top.position[2] == pytest.approx(3.5, abs=0.05)
    assert poses[-1].floor == 0 and poses[-1].position[2] == pytest.approx(0.0, abs=0.05)
    floors = [p.floor for p in poses]
    changes = [b for a, b in zip(floors, floors[1:]) if a != b]
    assert changes == [1, 0]                      # once up, once down: no flicker
    assert counts["strides_SC"] >= 9 and counts["strides_SDB"] >= 9
    assert counts.get("strides_SDF", 0) <= 1      # the descent is recognised as backward


@pytest.mark.parametrize("params", [{"gait": {"source": "odometry"}},
                                    {"height": {"source": "ins"}}],
                         ids=["ins_labels", "ins_height"])
def test_other_gait_and_height_sources(building, params):
    """The odometry's own motion labels, or the INS height change (drift-corrected)
    instead of counted stairs: the floors are right too."""
    up, w = stairwell_round_trip()
    poses, counts = run(building, w, labels=True, **params)
    top = [p for p in poses if p.t <= up.t[-1]][-1]
    assert top.floor == 1 and poses[-1].floor == 0
    if "gait" in params:
        assert counts["strides_SDB"] == 10 and counts["strides_SC"] == 10
    else:
        assert top.position[2] == pytest.approx(3.5, abs=0.1)   # snapped, then INS noise


def test_nominal_20cm_stairs_without_map_aid(building):
    """The paper's counting alone: 20 stairs climbed at 20 cm are 4.0 m; the floor is
    still right (floor 1 spans 1.75 m to 5.25 m). Without INS height noise: a stride of
    two 17.5 cm stairs is 1.75 nominal stairs, so noise would sometimes round it to one."""
    up, _ = stairwell_round_trip()
    poses, counts = run(building, up, dz_noise=0.0, height={
        "step_height_from_building": False, "floor_snap": 0.0, "stair_zone": None})
    assert poses[-1].position[2] == pytest.approx(20 * 0.20, abs=1e-6)
    assert poses[-1].floor == 1


def test_snap_levels_are_floors_and_landings(building):
    np.testing.assert_allclose(snap_levels(building), [0.0, 1.75, 3.5, 5.25, 7.0])


def test_classifier_learns_the_ins_vertical_drift():
    """Level walking with 6 cm of INS climb per metre north: the gradient is learnt and
    the strides stay level; a lone stair-like stride is retracted by the next one."""
    g = GaitClassifier()
    rng = np.random.default_rng(1)
    for k in range(40):
        a = rng.uniform(-math.pi, math.pi)
        d = 1.2 * np.array([math.cos(a), math.sin(a)])
        s = g.classify(np.array([*d, 0.06 * d[1]]), a)
        assert s.gait == "FW"
    np.testing.assert_allclose(g.gradient, [0.0, 0.06], atol=0.01)
    lone = g.classify(np.array([0.9, 0.0, 0.3]), 0.0)
    assert lone.gait == "SC"                      # counted at once ...
    nxt = g.classify(np.array([1.2, 0.0, 0.0]), 0.0)
    assert nxt.gait == "FW" and nxt.retract       # ... and taken back
