"""The shared angle wrap: (-pi, pi], exact at the boundary, any number of turns."""
import math

import pytest

from firenav_framework.geometry import wrap_angle


@pytest.mark.parametrize("angle, expected", [
    (0.0, 0.0), (math.pi, math.pi), (-math.pi, math.pi), (3 * math.pi, math.pi),
    (2 * math.pi + 0.5, 0.5), (-2 * math.pi - 0.5, -0.5), (100 * math.pi + 1.0, 1.0)])
def test_wrap_angle(angle, expected):
    assert wrap_angle(angle) == pytest.approx(expected, abs=1e-12)
    assert -math.pi < wrap_angle(angle) <= math.pi
