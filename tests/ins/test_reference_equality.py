"""The numba kernels compute exactly what the plain reference implementation computes."""
from __future__ import annotations

import numpy as np
import pytest

from firenav_plugins.estimators.zupt_ins import ZuptInsParams, detectors, eskf

from . import reference_ins as ref
from .conftest import FLU, run_engine
from .synthetic import Stride, add_noise, walk

N_REAL = 2500  # samples of the real trial compared (the reference is slow)


def _compare(t, acc, gyro, params: ZuptInsParams) -> None:
    dc, fc = params.detector_config(200.0), params.filter_config(200.0)
    ours = run_engine(t, acc, gyro, params)
    states, events, stat = ref.run(t, acc, gyro, dc, fc)
    np.testing.assert_allclose(ours.stat[:, 0], stat, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(ours.states[:, eskf.O_ZV], states[:, eskf.O_ZV])
    assert ours.states[:, eskf.O_ZV].any() and not ours.states[:, eskf.O_ZV].all()
    np.testing.assert_allclose(ours.states, states, rtol=0, atol=1e-9)
    assert len(ours.events) == len(events) > 0
    np.testing.assert_allclose(ours.events, events, rtol=0, atol=1e-9)


@pytest.mark.parametrize("options", [
    {},
    {"detector": {"kind": "shoe"}},
    {"filter": {"bias_states": True, "accel_bias_sigma": 0.01},
     "zaru": {"enabled": True, "after": 0.2}, "height": {"correction": True}},
])
def test_real_trial_matches_reference(vicon_run, options):
    s = slice(0, N_REAL)
    _compare(vicon_run.ts[s], vicon_run.accel[s] * FLU, vicon_run.gyro[s] * FLU,
             ZuptInsParams(**options))


def test_real_crawl_matches_reference(vicon_crawl):
    """Crawling: the adaptive detector's crawl levels take over (resting foot inverted)."""
    s = slice(0, N_REAL)
    params = ZuptInsParams()
    _compare(vicon_crawl.ts[s], vicon_crawl.accel[s] * FLU, vicon_crawl.gyro[s] * FLU, params)
    res = run_engine(vicon_crawl.ts[s], vicon_crawl.accel[s] * FLU, vicon_crawl.gyro[s] * FLU)
    assert (res.stat[:, 2] == detectors.MODE_CRAWL).mean() > 0.9


@pytest.mark.parametrize("detector,threshold", [("ared", None), ("amvd", 1e4)])
def test_synthetic_walk_matches_reference(detector, threshold):
    rec = add_noise(walk([Stride((0.7, 0.05, 0.0), turn=0.4), Stride((0.6, 0.0, 0.17)),
                          Stride((0.6, -0.1, 0.0), turn=-0.4)]), np.random.default_rng(1))
    # smooth synthetic swings barely change within a 25 ms window: AMVD needs a low threshold
    _compare(rec.t, rec.accel, rec.gyro, ZuptInsParams(detector={"kind": detector, "threshold": threshold}))
