"""The datasets' error measures on cases with known answers."""
from __future__ import annotations

import math

import numpy as np
import pytest

from firenav_plugins.estimators.zupt_ins.metrics import pyshoe_armse, rigid_fit_2d, stride_errors


def _rot(a):
    return np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])


def test_armse_ignores_start_offset_and_heading():
    t = np.linspace(0, 10, 500)
    truth = np.c_[np.cos(t), np.sin(2 * t)] * 2.0
    est = (truth - truth[0]) @ _rot(0.7).T + [5.0, -3.0]
    assert pyshoe_armse(est, truth) == pytest.approx(0.0, abs=1e-12)


def test_armse_of_an_offset_is_offset_over_sqrt2():
    # PyShoe's per-sample RMS runs over the two axes: a horizontal error e counts e/sqrt(2).
    # The estimate agrees with the truth up to the alignment sample (the first one 0.8 m
    # from the start), so the rotation is zero, then is off by e sideways.
    n, e = 300, 0.1
    truth = np.c_[np.linspace(0, 3, n), np.zeros(n)]
    ind = int(np.argmax(np.hypot(*truth[1:].T) >= 0.8))
    est = truth.copy()
    est[ind + 1:, 1] += e
    assert pyshoe_armse(est, truth) == pytest.approx((n - ind - 1) / n * e / math.sqrt(2),
                                                     rel=1e-12)


def test_rigid_fit_recovers_rotation_and_translation():
    rng = np.random.default_rng(0)
    src = rng.normal(size=(20, 2))
    R, t = _rot(-2.0), np.array([3.0, 1.0])
    rot, trans = rigid_fit_2d(src, src @ R.T + t)
    np.testing.assert_allclose(rot, R, atol=1e-12)
    np.testing.assert_allclose(trans, t, atol=1e-12)


def test_stride_errors_align_on_first_strides_only():
    truth = np.c_[np.arange(10.0), np.zeros(10)]
    est = truth @ _rot(1.0).T + [2.0, 2.0]
    est[6:] += [0.0, 0.5]          # the estimate goes wrong after the alignment strides
    e = stride_errors(est, truth, n_align=5)
    np.testing.assert_allclose(e.errors[:5], 0.0, atol=1e-12)
    np.testing.assert_allclose(e.errors[6:], 0.5, atol=1e-12)
    assert e.distance == pytest.approx(9.0)
    assert e.mean_percent == pytest.approx(100 * 0.5 * 4 / 10 / 9.0)


def test_bad_metric_input_is_a_clear_error():
    with pytest.raises(ValueError, match="equally long"):
        pyshoe_armse(np.zeros((5, 2)), np.zeros((6, 2)))
    with pytest.raises(ValueError, match="differ in shape"):
        stride_errors(np.zeros((5, 2)), np.zeros((4, 2)))
