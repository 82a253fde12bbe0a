"""ORCA half-planes and the collision-avoiding velocity against hand-worked geometry.

Setting used throughout: a long wall along y = 0, the agent (radius r) above it, moving
at speed s with its velocity pointing ``a`` below the wall direction. Permitted
velocities may approach the wall only as fast as the gap allows within the horizon:
``v_y >= -(d - r) / tau``; for a touching agent, not at all.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from firenav_framework.building import Floor
from firenav_plugins.constraints.orca.step_solver import (AVOIDED, FREE, WallGrid,
                                                          disc_contact)
from firenav_plugins.constraints.orca.velocity_obstacles import (smallest_rotation,
                                                                 solve_velocity,
                                                                 wall_orca_lines)

R, TAU, S = 0.25, 2.0, 1.3
NONE2 = np.zeros((0, 2))
NONE1 = np.zeros(0)


def grid_of(walls) -> WallGrid:
    return WallGrid(Floor(index=0, z=0.0, height=3.0, walls=np.asarray(walls, float)))


LONG_WALL = [[[-50.0, 0.0], [50.0, 0.0]]]


def step_into_wall(d: float, a_deg: float, dt: float = 1.0):
    pos = np.array([0.0, d])
    a = math.radians(a_deg)
    target = pos + S * dt * np.array([math.cos(a), -math.sin(a)])
    return grid_of(LONG_WALL).step(pos, target, dt, R, TAU, TAU, NONE2, NONE2, NONE1)


def test_touching_agent_heading_10_deg_into_wall_needs_10_deg():
    code, v, theta, wall, frac = step_into_wall(R, 10.0)
    assert code == AVOIDED and wall == 0 and frac == pytest.approx(0.0, abs=1e-5)
    assert math.degrees(theta) == pytest.approx(10.0, abs=1e-9)   # rotate back up to the wall
    # closest permitted velocity: the INS velocity with its component into the wall removed
    np.testing.assert_allclose(v, [S * math.cos(math.radians(10)), 0.0], atol=1e-12)


@pytest.mark.parametrize("gap", [0.02, 0.05, 0.1])
def test_gap_to_wall_allows_approach_within_the_horizon(gap):
    code, v, theta, _, _ = step_into_wall(R + gap, 10.0)
    assert code == AVOIDED
    allowed = gap / TAU                            # m/s towards the wall
    assert math.degrees(theta) == pytest.approx(10.0 - math.degrees(math.asin(allowed / S)),
                                                abs=1e-9)
    np.testing.assert_allclose(v, [S * math.cos(math.radians(10)), -allowed], atol=1e-12)


def test_head_on_into_wall_needs_a_right_angle():
    code, v, theta, _, _ = step_into_wall(R, 90.0)
    assert code == AVOIDED
    assert abs(math.degrees(theta)) == pytest.approx(90.0, abs=1e-9)
    np.testing.assert_allclose(v, [0.0, 0.0], atol=1e-12)


def test_step_that_stays_clear_is_free():
    # 10 deg down from 0.6 m: the step ends 0.6 - 1.3 sin 10 = 0.374 m > r from the wall
    code, v, theta, wall, _ = step_into_wall(0.6, 10.0)
    assert code == FREE and wall == -1 and theta == 0.0
    np.testing.assert_allclose(v, [S * math.cos(math.radians(10)), -S * math.sin(math.radians(10))])


def test_short_step_does_not_tunnel_through_wall():
    # a 4 m step straight through the wall from 1 m away: the horizon is at least the step
    pos, target = np.array([0.0, 1.0]), np.array([0.0, -3.0])
    code, v, theta, wall, frac = grid_of(LONG_WALL).step(pos, target, 1.0, R, 0.1, 0.1,
                                                        NONE2, NONE2, NONE1)
    assert code == AVOIDED and wall == 0
    assert frac == pytest.approx((1.0 - R) / 4.0, abs=1e-5)
    assert v[1] >= -(1.0 - R) / 1.0 - 1e-12        # stops at the wall within the step


def test_vertex_ahead_projects_velocity_onto_the_tangent_leg():
    """A wall end straight ahead at D: the velocity obstacle is the cone of half-angle
    asin(r / D) about the vertex direction; the closest permitted velocity is the
    projection onto a leg, |v| = s cos(beta)."""
    D = 2.0
    walls = np.array([[[D, 0.0], [D, -5.0]]])     # wall running away from the agent
    pos, vel = np.zeros(2), np.array([S, 0.0])
    pts, dirs = np.empty((2, 2)), np.empty((2, 2))
    n = wall_orca_lines(pos, vel, R, TAU, walls, np.array([0]), pts, dirs)
    assert n == 1
    out = np.empty(2)
    assert solve_velocity(pts, dirs, n, n, S, vel, out)
    beta = math.asin(R / D)
    assert np.hypot(*out) == pytest.approx(S * math.cos(beta), rel=1e-9)
    assert math.atan2(out[1], out[0]) == pytest.approx(beta, rel=1e-9)  # passes above the end
    theta = smallest_rotation(vel, pts, dirs, n)
    assert theta == pytest.approx(beta, rel=1e-9)


def test_boxed_in_agent_has_no_rotation():
    # in a 0.6 m wide dead end, walking into its end wall: no heading at this speed is free
    walls = [[[-5.0, -0.3], [0.5, -0.3]], [[-5.0, 0.3], [0.5, 0.3]], [[0.5, -0.3], [0.5, 0.3]]]
    pos, target = np.array([0.0, 0.0]), np.array([1.3, 0.0])
    code, v, theta, wall, _ = grid_of(walls).step(pos, target, 1.0, R, TAU, TAU, NONE2,
                                                  NONE2, NONE1)
    assert code == AVOIDED and math.isnan(theta)
    assert v[0] <= (0.5 - R) / TAU + 1e-12


def test_disc_contact_fraction():
    # disc of 0.25 moving from y=1 to y=-1 towards the wall y=0 between x=-1..1
    assert disc_contact(0, 1, 0, -1, 0.25, -1, 0, 1, 0) == pytest.approx(0.375)
    # passing beside the wall's end at 0.2 m: the end vertex circle is hit
    f = disc_contact(1.2, 1, 1.2, -1, 0.25, -1, 0, 1, 0)
    assert f == pytest.approx((1.0 - math.sqrt(0.25 ** 2 - 0.2 ** 2)) / 2.0)
    # passing 0.3 m beside it: no contact; already touching: 0
    assert disc_contact(1.3, 1, 1.3, -1, 0.25, -1, 0, 1, 0) == -1.0
    assert disc_contact(0, 0.1, 1, 0.1, 0.25, -1, 0, 1, 0) == 0.0
