"""The compartment doubt: grows with distance walked, narrows only along a range's line."""
import math

import numpy as np

from firenav_plugins.constraints.orca.compartment import CompartmentDoubt


def test_sigma_grows_linearly_with_distance_walked():
    d = CompartmentDoubt(0.05)
    for _ in range(100):
        d.walk(1.0)                       # 100 m in 1 m steps
    assert math.isclose(math.sqrt(d.cov[0, 0]), 5.0, rel_tol=1e-9)
    assert math.isclose(math.sqrt(d.cov[1, 1]), 5.0, rel_tol=1e-9)


def test_a_range_narrows_only_along_the_line_to_the_anchor():
    d = CompartmentDoubt(0.05)
    for _ in range(100):
        d.walk(1.0)
    d.range_to(np.array([10.0, 0.0, 0.0]), np.array([0.0, 0.0, 0.0]), 0.5)
    # scalar Kalman update along x: 25 * 0.25 / (25 + 0.25)
    assert math.isclose(d.cov[0, 0], 25 * 0.25 / 25.25, rel_tol=1e-9)
    assert math.isclose(d.cov[1, 1], 25.0, rel_tol=1e-9)


def test_no_growth_keeps_no_doubt():
    d = CompartmentDoubt(0.0)
    d.walk(50.0)
    assert np.all(d.cov == 0.0)
