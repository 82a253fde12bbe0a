"""Synthetic walks shared by the breadcrumb benchmarks and tests (one home for the loop)."""
from __future__ import annotations

import numpy as np


def loop_path(laps: int) -> np.ndarray:
    """True foot positions (N, 3) [m, ENU, z = 0], 1 m apart, around a 40 m x 10 m loop
    anticlockwise from the base-station corner (0, 0), ``laps`` times."""
    corners = np.array([[0, 0], [40, 0], [40, 10], [0, 10], [0, 0]], float)
    pts = [corners[0]]
    for _ in range(laps):
        for a, b in zip(corners[:-1], corners[1:]):
            n = int(np.linalg.norm(b - a))
            pts.extend(a + (b - a) * k / n for k in range(1, n + 1))
    return np.c_[np.array(pts), np.zeros(len(pts))]
