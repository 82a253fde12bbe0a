"""Issue 15: ORCA in a wrong corridor is never trusted there, and its radius holds the truth.

A 2 m entry corridor runs 41 m north (x 0..2 m); at its top two parallel 2 m corridors
branch off east, B (y -3..-1 m) and, a 1 m block further north, A (y 0..2 m). The walker
walks up the entry corridor and turns into A; its foot INS measures every stride 8 %
short (a crouched gait in smoke), 2.7 times the estimator's own 3 % scale sigma, so the
dead-reckoned track turns east 3.1 m early, into B, and follows it while the walker
follows A. B's walls hold the track exactly as A's would hold the right one: without the
compartment doubt they shrink the covariance to B's width and the pose is trusted 3-4 m
off. No UWB (as ff4 on ``incident``): nothing but the odometry says which corridor.

The walk runs through ``dead_reckoning`` (its drift and integrity defaults, which the
bundled ``orca-map-matching`` pipeline keeps; the start pose given) with the constraints
of that pipeline's ``mm`` as it configures them (anchor_range, wall_follow, orca: the
real components, in order), scripted as the other ORCA tests' walker; the truth is the
scripted building-frame path.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from firenav_framework.pipeline import load_pipeline
from tests.orca.walker import Walker, building

#: Entry corridor x 0..2 m from y = -40 m; B y -3..-1 m and A y 0..2 m east to x = 40 m.
WALLS = [
    [[0.0, -40.0], [0.0, 6.0]], [[0.0, -40.0], [2.0, -40.0]], [[2.0, -40.0], [2.0, -3.0]],
    [[2.0, -3.0], [40.0, -3.0]], [[2.0, -1.0], [40.0, -1.0]], [[40.0, -3.0], [40.0, -1.0]],
    [[2.0, -1.0], [2.0, 0.0]],                                   # the block's west face
    [[2.0, 0.0], [40.0, 0.0]], [[2.0, 2.0], [40.0, 2.0]], [[40.0, 0.0], [40.0, 2.0]],
    [[2.0, 2.0], [2.0, 6.0]], [[0.0, 6.0], [2.0, 6.0]],
]
START = (1.0, -38.0)         # [m], heading north
STRIDE = 0.8                 # true stride [m], one a second
SCALE = 0.92                 # the INS's measured / true stride length
NORTH, EAST = 49, 42         # strides up the entry corridor (to y = 1.2 m in A) and along A


def walk(repo, overrides: list[str]) -> dict[str, np.ndarray]:
    """The walk through the bundled pipeline's ``mm`` and its constraints: per pose the
    truth (N, 2) [m], the estimate (N, 2) [m], the protection radius (N,) [m] and
    whether it was trusted (N,)."""
    spec = load_pipeline(repo / "pipelines" / "orca-map-matching.yaml", overrides)
    chain = [(c.cls, c.params) for c in spec.of_kind("constraint") if c.parent == "mm"]
    w = Walker(building(WALLS), START, math.pi / 2, extra=chain)
    truth, true_xy = np.array(START), []
    for k in range(NORTH + EAST):
        north = k < NORTH
        move = np.array([0.0, STRIDE] if north else [STRIDE, 0.0])
        truth = truth + move
        true_xy.append(truth)
        w.step(*(SCALE * move), turn=-math.pi / 2 if k == NORTH else 0.0)
    poses = w.rec.on("pose")
    return {"truth": np.array(true_xy), "estimate": np.array([p.position[:2] for p in poses]),
            "radius": np.array([p.protection_radius for p in poses]),
            "trusted": np.array([p.trusted for p in poses])}


@pytest.fixture(scope="module")
def default(repo):
    return walk(repo, [])


def in_wrong_corridor(run) -> np.ndarray:
    """Poses whose estimate is in B (x > 2 m, y -3..-1 m) while the truth is in A."""
    est, truth = run["estimate"], run["truth"]
    return (est[:, 0] > 2.0) & (est[:, 1] > -3.0) & (est[:, 1] < -1.0) & (truth[:, 1] > 0.0)


def test_the_track_follows_the_wrong_corridor(default):
    """The premise: the track runs the length of B (the walls hold it there), 3-4 m from
    the walker in A."""
    wrong = in_wrong_corridor(default)
    assert wrong.sum() >= EAST - 2
    err = np.hypot(*(default["estimate"] - default["truth"]).T)
    assert np.all(err[wrong] > 3.0)


def test_never_trusted_while_more_than_3_m_off(default):
    err = np.hypot(*(default["estimate"] - default["truth"]).T)
    assert not np.any(default["trusted"] & (err > 3.0))


def test_in_the_wrong_corridor_the_radius_holds_the_truth(default):
    """The scripted truth against the 99 % protection radius on every pose in B."""
    wrong = in_wrong_corridor(default)
    err = np.hypot(*(default["estimate"] - default["truth"]).T)
    assert np.all(err[wrong] <= default["radius"][wrong])


def test_without_the_doubt_the_wrong_corridor_is_trusted(repo):
    """The same walk with ``compartment_growth: 0`` (the estimator's covariance alone
    decides whether the walker is between B's walls): B's walls shrink the covariance and
    most of the wrong-corridor poses are trusted with a radius short of the error."""
    run = walk(repo, ["estimators.mm.constraints.orca.compartment_growth=0"])
    wrong = in_wrong_corridor(run)
    err = np.hypot(*(run["estimate"] - run["truth"]).T)
    assert wrong.sum() >= EAST - 2
    assert np.mean(run["trusted"][wrong]) > 0.5
    assert np.mean(err[wrong] > run["radius"][wrong]) > 0.5
