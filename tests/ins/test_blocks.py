"""Processing a recording in blocks gives bit-identical results to processing it whole."""
from __future__ import annotations

import numpy as np

from firenav_framework import ImuBlock
from firenav_framework.testing import run_component
from firenav_plugins.estimators.zupt_ins import ZuptInsEstimator

from .conftest import FLU, run_engine


def _cuts(n: int, rng: np.random.Generator, end: int = 3000) -> list[int]:
    # blocks of 1 to 120 samples (5 ms to 0.6 s at 200 Hz), cut positions below ``end``
    return [int(c) for c in np.cumsum(rng.integers(1, 120, size=n)) if c < end]


def test_engine_blocks_equal_whole(vicon_run):
    s = slice(0, 4000)
    t, acc, gyro = vicon_run.ts[s], vicon_run.accel[s] * FLU, vicon_run.gyro[s] * FLU
    whole = run_engine(t, acc, gyro)
    cuts = _cuts(200, np.random.default_rng(0), len(t))
    split = run_engine(t, acc, gyro, blocks=cuts)
    assert len(whole.events) > 10
    np.testing.assert_array_equal(whole.states, split.states)
    np.testing.assert_array_equal(whole.events, split.events)
    np.testing.assert_array_equal(whole.stat, split.stat)


def _blocks(t, acc, gyro, cuts, agent="ff1"):
    edges = [0, *cuts, len(t)]
    return [("imu", ImuBlock.from_arrays(t[a:b], acc[a:b], gyro[a:b], agent=agent,
                                         device=f"{agent}/imu"))
            for a, b in zip(edges[:-1], edges[1:]) if b > a]


def _digest(rec, port):
    return [m.digest() for m in rec.on(port)]


def test_plugin_blocks_equal_whole(vicon_walk):
    s = slice(0, 3000)
    t, acc, gyro = vicon_walk.ts[s], vicon_walk.accel[s] * FLU, vicon_walk.gyro[s] * FLU
    params = {"outputs": {"state_rate": 50.0}}
    whole = run_component(ZuptInsEstimator, params, _blocks(t, acc, gyro, [20]))
    split = run_component(ZuptInsEstimator, params,
                          _blocks(t, acc, gyro, _cuts(100, np.random.default_rng(3))))
    assert len(whole.on("odometry")) > 5 and len(whole.on("state")) > 100
    for port in ("odometry", "pose", "state"):
        assert _digest(whole, port) == _digest(split, port), port


def test_plugin_state_is_the_retro_corrected_track(vicon_walk):
    """The streamed 'state' port equals the whole-recording retrospective correction."""
    from firenav_plugins.estimators.zupt_ins import eskf
    from firenav_plugins.estimators.zupt_ins.retro import correct_positions

    s = slice(0, 3000)
    t, acc, gyro = vicon_walk.ts[s], vicon_walk.accel[s] * FLU, vicon_walk.gyro[s] * FLU
    rec = run_component(ZuptInsEstimator, {"outputs": {"state_rate": 200.0}}, _blocks(t, acc, gyro, _cuts(
        60, np.random.default_rng(9))))
    whole = run_engine(t, acc, gyro)
    pos = correct_positions(whole.states[:, eskf.O_T], whole.states[:, 1:4], whole.events)
    moved = np.abs(pos - whole.states[:, 1:4]).max()
    assert moved > 1e-3   # the correction does something
    states = rec.on("state")
    idx = np.searchsorted(whole.states[:, eskf.O_T], [m.t for m in states])
    np.testing.assert_allclose(np.array([m.position for m in states]), pos[idx], atol=1e-12)
