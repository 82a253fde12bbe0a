"""One ORCA step for one agent: collision detection, then the collision-avoiding velocity.

For each new INS position the agent (a disc of radius ``r`` at its corrected position)
would move to, :func:`orca_step` checks whether the move touches a wall or another
agent (Algorithm 1, line 22, ``IsCollision``) and, if so, returns the ORCA velocity
closest to the INS velocity (line 23; §2.2 eqs. 3-7). Only the walls near the agent
are visited, through the building's spatial query
(:func:`~firenav_framework.building.index.segments_near_sorted` on the floor's
``Floor.wall_index``), so the cost per step does not grow with the size of the floor.

Everything here is one compiled call per step; :class:`WallGrid` holds the grid
arrays and the scratch buffers between calls.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from firenav_framework.building.index import segments_near_sorted

from .velocity_obstacles import (agent_orca_lines, smallest_rotation, solve_velocity,
                                 wall_orca_lines)

#: Results of :func:`orca_step`.
FREE, AVOIDED, LEAST_VIOLATION = 0, 1, 2

#: A move closer than this to an obstacle [m] (beyond the radius) counts as touching.
CONTACT_TOL = 1e-6


@njit(cache=True)
def _point_seg_dist2(px, py, ax, ay, bx, by):
    ex, ey = bx - ax, by - ay
    l2 = ex * ex + ey * ey
    u = 0.0
    if l2 > 0.0:
        u = min(1.0, max(0.0, ((px - ax) * ex + (py - ay) * ey) / l2))
    cx, cy = ax + u * ex - px, ay + u * ey - py
    return cx * cx + cy * cy


@njit(cache=True)
def _circle_entry(px, py, mx, my, cx, cy, r) -> float:
    """Smallest s in [0, 1] with |p + s m - c| <= r, or -1."""
    fx, fy = px - cx, py - cy
    c = fx * fx + fy * fy - r * r
    if c <= 0.0:
        return 0.0
    a = mx * mx + my * my
    b = fx * mx + fy * my
    disc = b * b - a * c
    if a == 0.0 or b >= 0.0 or disc < 0.0:
        return -1.0
    s = (-b - math.sqrt(disc)) / a
    return s if s <= 1.0 else -1.0


@njit(cache=True)
def disc_contact(p0x, p0y, p1x, p1y, r, ax, ay, bx, by) -> float:
    """Fraction s in [0, 1] of the move p0 -> p1 at which a disc of radius ``r`` [m]
    first touches segment a-b (0 if it already does), or -1 if it never does."""
    mx, my = p1x - p0x, p1y - p0y
    best = _circle_entry(p0x, p0y, mx, my, ax, ay, r)
    s2 = _circle_entry(p0x, p0y, mx, my, bx, by, r)
    if s2 >= 0.0 and (best < 0.0 or s2 < best):
        best = s2
    if best == 0.0:
        return 0.0
    ex, ey = bx - ax, by - ay
    length = math.sqrt(ex * ex + ey * ey)
    if length == 0.0:
        return best
    ux, uy = ex / length, ey / length
    h0 = -uy * (p0x - ax) + ux * (p0y - ay)       # signed distance of p0 from the line
    dh = -uy * mx + ux * my
    if abs(h0) <= r:
        along = ux * (p0x - ax) + uy * (p0y - ay)
        if 0.0 <= along <= length:
            return 0.0
    elif h0 * dh < 0.0:
        s = (abs(h0) - r) / abs(dh)                 # reaches the band |h| = r
        if s <= 1.0:
            along = ux * (p0x + s * mx - ax) + uy * (p0y + s * my - ay)
            if 0.0 <= along <= length and (best < 0.0 or s < best):
                best = s
    return best


@njit(cache=True)
def orca_step(pos, target, dt, radius, tau, tau_agents, segs, start, items, ox, oy, h, nx, ny,
              stamp, tag, cand, dist2, others_pos, others_vel, others_radius,
              pts, dirs, out_vel) -> tuple[int, float, int, float, int]:
    """Collision check of the move ``pos`` -> ``target`` (2,) [m] over ``dt`` [s], and ORCA.

    Returns ``(code, theta, wall, frac, n_lines)``. ``code`` is FREE (the disc of
    ``radius`` [m] sweeps past every wall and agent; ``out_vel`` is the INS velocity),
    AVOIDED (``out_vel`` is the
    ORCA velocity of eq. 6: the permitted velocity closest to the INS velocity, no
    faster) or LEAST_VIOLATION (no velocity meets every constraint, e.g. agents
    overlapping; the least-violating one). ``theta`` [rad] is the smallest rotation of
    the INS velocity, at its speed, into the permitted set (Figure 4; NaN when none
    exists, 0 when FREE). ``wall`` is the wall the disc touches first (-1 when only an
    agent is in the way), ``frac`` the fraction of the move at that contact and
    ``n_lines`` the number of ORCA lines left in ``pts``/``dirs``. The obstacle time
    horizon is ``max(tau, dt)`` so that a step can never tunnel through a wall.
    ``stamp``, ``tag``, ``cand`` and ``dist2`` are the scratch buffers of
    :func:`~firenav_framework.building.index.segments_near_sorted`.
    """
    vx, vy = (target[0] - pos[0]) / dt, (target[1] - pos[1]) / dt
    out_vel[0], out_vel[1] = vx, vy
    speed = math.sqrt(vx * vx + vy * vy)
    step = speed * dt
    tau_o = max(tau, dt)
    reach = max(tau_o * speed, step) + radius
    n = segments_near_sorted(pos[0], pos[1], reach, segs, start, items, ox, oy, h, nx, ny,
                             stamp, tag, cand, dist2)
    first, wall = 2.0, -1
    for k in range(n):
        if dist2[k] > (step + radius) ** 2:
            break
        w = cand[k]
        f = disc_contact(pos[0], pos[1], target[0], target[1], radius - CONTACT_TOL,
                         segs[w, 0, 0], segs[w, 0, 1], segs[w, 1, 0], segs[w, 1, 1])
        if f >= 0.0 and (f < first or (f == first and w < wall)):
            first, wall = f, w
    hit = wall >= 0
    if not hit:
        for i in range(others_pos.shape[0]):
            if _point_seg_dist2(others_pos[i, 0], others_pos[i, 1], pos[0], pos[1],
                                target[0], target[1]) < (radius + others_radius[i]) ** 2:
                hit = True
                break
    if not hit or speed == 0.0:
        return FREE, 0.0, -1, math.nan, 0
    vel = np.empty(2)
    vel[0], vel[1] = vx, vy
    n_obst = wall_orca_lines(pos, vel, radius, tau_o, segs, cand[:n], pts, dirs)
    n_lines = agent_orca_lines(pos, vel, radius, max(tau_agents, dt), dt, others_pos,
                               others_vel, others_radius, pts, dirs, n_obst)
    theta = smallest_rotation(vel, pts, dirs, n_lines)
    code = AVOIDED if solve_velocity(pts, dirs, n_lines, n_obst, speed, vel, out_vel) \
        else LEAST_VIOLATION
    return code, theta, wall, first, n_lines


class WallGrid:
    """The walls of one floor with their grid (from the building model) and scratch buffers."""

    def __init__(self, floor, max_agents: int = 64):
        segs, self.start, self.items, ox, oy, h, nx, ny = floor.wall_index.grid_args()
        self.segs = np.ascontiguousarray(segs, dtype=np.float64)
        self.grid = (ox, oy, h, int(nx), int(ny))
        n = len(self.segs)
        self.stamp = np.full(max(n, 1), -1, dtype=np.int64)
        self.tag = 0
        self.cand = np.empty(max(n, 1), dtype=np.int64)
        self.dist2 = np.empty(max(n, 1))
        self.pts = np.empty((n + max_agents + 1, 2))
        self.dirs = np.empty((n + max_agents + 1, 2))
        self.vel = np.empty(2)
        self.n_lines = 0

    def step(self, pos: np.ndarray, target: np.ndarray, dt: float, radius: float, tau: float,
             tau_agents: float, others_pos: np.ndarray, others_vel: np.ndarray,
             others_radius: np.ndarray) -> tuple[int, np.ndarray, float, int, float]:
        """:func:`orca_step` on this floor: (code, ORCA velocity (2,) [m/s], theta [rad],
        first wall touched, fraction of the move at that contact)."""
        self.tag += 1
        ox, oy, h, nx, ny = self.grid
        code, theta, wall, frac, self.n_lines = orca_step(
            pos, target, dt, radius, tau, tau_agents, self.segs, self.start, self.items, ox, oy,
            h, nx, ny, self.stamp, self.tag, self.cand, self.dist2, others_pos, others_vel,
            others_radius, self.pts, self.dirs, self.vel)
        return code, self.vel.copy(), theta, wall, frac

    def rotation_for(self, vel: np.ndarray) -> float:
        """Smallest rotation [rad] of ``vel`` (2,) [m/s] into the ORCA set of the last
        :meth:`step` (NaN when none; 0 when that step was free)."""
        return smallest_rotation(vel, self.pts, self.dirs, self.n_lines)

    def blocked(self, p0: np.ndarray, p1: np.ndarray, radius: float) -> bool:
        """Does a disc of ``radius`` [m] moving p0 -> p1 (2,) touch a wall?"""
        self.tag += 1
        ox, oy, h, nx, ny = self.grid
        return _sweep_hits(p0, p1, radius, self.segs, self.start, self.items, ox, oy, h, nx,
                           ny, self.stamp, self.tag, self.cand, self.dist2)


@njit(cache=True)
def _sweep_hits(p0, p1, radius, segs, start, items, ox, oy, h, nx, ny, stamp, tag, cand,
                dist2) -> bool:
    step = math.sqrt((p1[0] - p0[0]) ** 2 + (p1[1] - p0[1]) ** 2)
    n = segments_near_sorted(p0[0], p0[1], step + radius, segs, start, items, ox, oy, h, nx,
                             ny, stamp, tag, cand, dist2)
    for k in range(n):
        w = cand[k]
        if disc_contact(p0[0], p0[1], p1[0], p1[1], radius - CONTACT_TOL, segs[w, 0, 0],
                        segs[w, 0, 1], segs[w, 1, 0], segs[w, 1, 1]) >= 0.0:
            return True
    return False
