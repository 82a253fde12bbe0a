"""ORCA on Aamks obstacle JSON (the paper's map format, §2.2) read by the building model."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from firenav_framework.building import load_building
from firenav_framework.testing import make_component
from firenav_plugins.constraints.orca import OrcaConstraint
from firenav_plugins.constraints.orca.step_solver import AVOIDED, WallGrid

NONE2, NONE1 = np.zeros((0, 2)), np.zeros(0)


def corridor_json(tmp_path):
    """The paper's printed format: per-floor thin wall rectangles in centimetres."""
    walls = [[[0, 690], [4000, 690], [4000, 694], [0, 694]],        # y = 6.92 m
             [[0, 990], [4000, 990], [4000, 994], [0, 994]]]        # y = 9.92 m
    path = tmp_path / "corridor.json"
    path.write_text(json.dumps({"obstacles": {"1": walls}}))
    return path


def test_paper_format_walls_steer_the_agent(tmp_path):
    b = load_building(corridor_json(tmp_path))
    grid = WallGrid(b.floors[0])
    # touching the south wall's centre line (6.92 m) and heading 10 deg into it
    pos = np.array([10.0, 6.92 + 0.25])
    a = math.radians(10)
    target = pos + 1.3 * np.array([math.cos(a), -math.sin(a)])
    code, v, theta, wall, _ = grid.step(pos, target, 1.0, 0.25, 2.0, 2.0, NONE2, NONE2, NONE1)
    assert code == AVOIDED
    assert math.degrees(theta) == pytest.approx(10.0, abs=1e-6)
    orca, _, _ = make_component(OrcaConstraint, {}, building=b)
    orca.start()                                     # needs nothing but the walls


def test_real_aamks_export_every_wall_blocks(shared_data):
    """The real export in ../shared/data: walking square into the middle of any of its
    walls from 0.5 m is stopped at the agent radius."""
    b = load_building(shared_data / "aamks" / "simple.static.json")
    floor = b.floors[0]
    grid = WallGrid(floor)
    for w in floor.walls:
        e = w[1] - w[0]
        n = np.array([-e[1], e[0]]) / np.hypot(*e)
        mid = w.mean(axis=0)
        for side in (1.0, -1.0):
            pos = mid + side * 0.5 * n
            code, v, theta, hit, _ = grid.step(pos, mid - side * 0.5 * n, 1.0, 0.25, 2.0, 2.0,
                                               NONE2, NONE2, NONE1)
            assert code == AVOIDED
            # never closer to the wall than the radius after the step
            end = pos + v
            assert float(np.min(floor.nearest_wall(end[None])[0])) >= 0.25 - 1e-6
