"""The simulator's treads and landings agree with the building model's flights."""
from __future__ import annotations

import numpy as np
import pytest

from firenav_framework.building.model import Stair
from firenav_framework.simulator.movement import stair_geometry


def _treads_per_flight(st: Stair) -> list[int]:
    """Treads on the first and on the last segment of the walking line."""
    s_tread, *_ = stair_geometry(st)
    seg = np.linalg.norm(np.diff(st.path, axis=0), axis=1)
    first_end, last_start = seg[0], seg[:-1].sum()
    return [int((s_tread < first_end).sum()), int((s_tread > last_start).sum())]


@pytest.mark.parametrize("top_first", [False, True])
def test_a_short_first_flight_keeps_one_step_as_the_model_says(top_first):
    # U stair: a 0.1 m first flight, a 2 m landing, a 10 m last flight, 18 steps. A split in
    # proportion to length alone gives the short flight no step (floor(18 * 0.1 / 10.1) = 0);
    # the model's flights give each flight at least one.
    line = np.array([[0, 0], [0, 0.1], [2, 0.1], [2, 10.1]], float)
    z = (3.0, 0.0) if top_first else (0.0, 3.0)
    st = Stair("u", 0, 1, line, 1.0, *z, 18)
    low, high = st.flights()
    walked = [high.n_steps, low.n_steps] if top_first else [low.n_steps, high.n_steps]
    assert min(walked) == 1 and sum(walked) == 18
    assert _treads_per_flight(st) == walked
    s_tread, z_tread, s_land, z_land, length = stair_geometry(st)
    assert len(s_tread) == 18 and length == pytest.approx(12.1)
    # the landing is level at the height reached after the first flight walked
    assert np.allclose(z_land, z[0] + (z[1] - z[0]) * walked[0] / 18)
