"""ORCA half-planes for a disc agent among wall segments and other agents, and the LP.

This is the velocity-obstacle machinery of the ORCA map-matching paper (§2.2, eqs. 3-6),
which follows van den Berg et al.'s Optimal Reciprocal Collision Avoidance. Each
obstacle or other agent contributes one half-plane ("ORCA line") of permitted
velocities; the new velocity is the permitted velocity closest to the preferred one
(the INS velocity, eq. 7) inside the speed disc, found by an incremental 2-D linear
program. The structure follows the public RVO2 library (``Agent::computeNewVelocity``,
``linearProgram1/2/3``), rewritten here for numba with walls as two-sided segments
(RVO2's two-vertex obstacles):

* a wall segment is seen from the side the agent is on (RVO2's back-face culling);
* its velocity obstacle for time horizon ``tau`` is the segment scaled by ``1/tau``
  and grown by ``r/tau`` (eq. 3 with the Minkowski sum of eq. 4), bounded by two legs
  tangent to the end-vertex discs;
* the ORCA line is the tangent to that obstacle at the point closest to the current
  velocity; for an agent already touching the wall, the line forbids any velocity
  component into the wall.

Vectors are 2-D ENU [m] or [m/s]; lines are stored as a point and a unit direction,
with the permitted side on the *left* of the direction (RVO2's convention).
All functions are ``@njit(cache=True)`` and allocation-light: they run once per step.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

#: Tolerance of the geometric predicates (RVO2 uses the same value).
EPS = 1e-5


@njit(cache=True, inline="always")
def _det(ax: float, ay: float, bx: float, by: float) -> float:
    return ax * by - ay * bx


@njit(cache=True, inline="always")
def _tangent_legs(rx: float, ry: float, dist2: float, radius: float, r2: float):
    """Unit directions (left x, y, right x, y) of the two tangents from the agent to the
    disc of ``radius`` (``r2`` its square) about the vertex at (rx, ry) relative to the
    agent, ``dist2`` = rx^2 + ry^2 (RVO2's obstacle legs)."""
    leg = math.sqrt(dist2 - r2)
    return ((rx * leg - ry * radius) / dist2, (rx * radius + ry * leg) / dist2,
            (rx * leg + ry * radius) / dist2, (-rx * radius + ry * leg) / dist2)


@njit(cache=True, inline="always")
def _tangent_to_circle(vx: float, vy: float, cx: float, cy: float, r: float,
                       pts: np.ndarray, dirs: np.ndarray, n: int) -> None:
    """Line ``n``: the tangent to the circle (centre (cx, cy), radius ``r``) at the point
    nearest the velocity (vx, vy), the circle's outside permitted."""
    wx, wy = vx - cx, vy - cy
    wn = math.sqrt(wx * wx + wy * wy)
    if wn > 0.0:
        wx, wy = wx / wn, wy / wn
    dirs[n, 0], dirs[n, 1] = wy, -wx
    pts[n, 0], pts[n, 1] = cx + r * wx, cy + r * wy


@njit(cache=True, inline="always")
def _offset_line(cx: float, cy: float, dx: float, dy: float, r: float,
                 pts: np.ndarray, dirs: np.ndarray, n: int) -> None:
    """Line ``n``: direction (dx, dy), through (cx, cy) moved ``r`` to its left."""
    dirs[n, 0], dirs[n, 1] = dx, dy
    pts[n, 0] = cx + r * -dy
    pts[n, 1] = cy + r * dx


@njit(cache=True)
def wall_orca_lines(pos: np.ndarray, vel: np.ndarray, radius: float, tau: float,
                    walls: np.ndarray, order: np.ndarray,
                    pts: np.ndarray, dirs: np.ndarray) -> int:
    """Append the ORCA lines of the walls ``walls[order]`` to ``pts``/``dirs``.

    ``pos`` (2,) agent centre, ``vel`` (2,) its current velocity [m/s], ``radius``
    [m], ``tau`` the obstacle time horizon [s]; ``walls`` (W, 2, 2) segments;
    ``order`` the candidate wall indices, nearest first (nearer walls make the
    farther ones redundant, as in RVO2). Returns the number of lines written.
    """
    inv_tau = 1.0 / tau
    r2 = radius * radius
    n = 0
    for k in range(order.shape[0]):
        w = order[k]
        ax, ay = walls[w, 0, 0], walls[w, 0, 1]
        bx, by = walls[w, 1, 0], walls[w, 1, 1]
        # see the wall from the agent's side: the agent is right of the edge p1 -> p2
        if _det(ax - pos[0], ay - pos[1], bx - ax, by - ay) > 0.0:
            ax, ay, bx, by = bx, by, ax, ay
        ex, ey = bx - ax, by - ay
        elen2 = ex * ex + ey * ey
        if elen2 <= 0.0:
            continue
        elen = math.sqrt(elen2)
        dx, dy = ex / elen, ey / elen          # direction of vertex p1; p2's is -d
        r1x, r1y = ax - pos[0], ay - pos[1]    # relative positions of the vertices
        r2x, r2y = bx - pos[0], by - pos[1]

        covered = False
        for j in range(n):
            if (_det(inv_tau * r1x - pts[j, 0], inv_tau * r1y - pts[j, 1],
                     dirs[j, 0], dirs[j, 1]) - inv_tau * radius >= -EPS
                    and _det(inv_tau * r2x - pts[j, 0], inv_tau * r2y - pts[j, 1],
                             dirs[j, 0], dirs[j, 1]) - inv_tau * radius >= -EPS):
                covered = True
                break
        if covered:
            continue

        dist1 = r1x * r1x + r1y * r1y
        dist2 = r2x * r2x + r2y * r2y
        s = (-r1x * ex - r1y * ey) / elen2
        lx, ly = -r1x - s * ex, -r1y - s * ey
        dist_line = lx * lx + ly * ly

        # -- already in contact: forbid motion into the vertex or the segment
        if s < 0.0 and dist1 <= r2:
            nrm = math.sqrt(dist1)
            if nrm > 0.0:
                pts[n, 0], pts[n, 1] = 0.0, 0.0
                dirs[n, 0], dirs[n, 1] = -r1y / nrm, r1x / nrm
                n += 1
            continue
        if s > 1.0 and dist2 <= r2:
            nrm = math.sqrt(dist2)
            if nrm > 0.0 and _det(r2x, r2y, -dx, -dy) >= 0.0:
                pts[n, 0], pts[n, 1] = 0.0, 0.0
                dirs[n, 0], dirs[n, 1] = -r2y / nrm, r2x / nrm
                n += 1
            continue
        if 0.0 <= s <= 1.0 and dist_line <= r2:
            pts[n, 0], pts[n, 1] = 0.0, 0.0
            dirs[n, 0], dirs[n, 1] = -dx, -dy
            n += 1
            continue

        # -- no contact: legs of the truncated cone (one vertex when seen obliquely)
        same = False
        if s < 0.0 and dist_line <= r2:
            same = True                          # p1 alone defines the obstacle
            o1x, o1y, o1dx, o1dy = r1x, r1y, dx, dy
            o2dx, o2dy = dx, dy
            llx, lly, rlx, rly = _tangent_legs(r1x, r1y, dist1, radius, r2)
            o2x, o2y = r1x, r1y
        elif s > 1.0 and dist_line <= r2:
            same = True                          # p2 alone defines the obstacle
            o1x, o1y, o1dx, o1dy = r2x, r2y, -dx, -dy
            o2dx, o2dy = -dx, -dy
            llx, lly, rlx, rly = _tangent_legs(r2x, r2y, dist2, radius, r2)
            o2x, o2y = r2x, r2y
        else:
            o1x, o1y, o1dx, o1dy = r1x, r1y, dx, dy
            o2x, o2y, o2dx, o2dy = r2x, r2y, -dx, -dy
            llx, lly, _, _ = _tangent_legs(r1x, r1y, dist1, radius, r2)
            _, _, rlx, rly = _tangent_legs(r2x, r2y, dist2, radius, r2)

        # a leg may not point into the neighbouring edge: use that edge instead
        # (for a two-vertex obstacle the neighbour of a vertex runs back along it)
        left_foreign = False
        right_foreign = False
        if _det(llx, lly, o1dx, o1dy) >= 0.0:
            llx, lly = o1dx, o1dy
            left_foreign = True
        if _det(rlx, rly, o2dx, o2dy) <= 0.0:
            rlx, rly = o2dx, o2dy
            right_foreign = True

        lcx, lcy = inv_tau * o1x, inv_tau * o1y   # cut-off centres
        rcx, rcy = inv_tau * o2x, inv_tau * o2y
        cvx, cvy = rcx - lcx, rcy - lcy
        if same:
            t = 0.5
        else:
            t = ((vel[0] - lcx) * cvx + (vel[1] - lcy) * cvy) / (cvx * cvx + cvy * cvy)
        t_left = (vel[0] - lcx) * llx + (vel[1] - lcy) * lly
        t_right = (vel[0] - rcx) * rlx + (vel[1] - rcy) * rly

        r_tau = radius * inv_tau
        if (t < 0.0 and t_left < 0.0) or (same and t_left < 0.0 and t_right < 0.0):
            _tangent_to_circle(vel[0], vel[1], lcx, lcy, r_tau, pts, dirs, n)  # left cut-off
            n += 1
            continue
        if t > 1.0 and t_right < 0.0:
            _tangent_to_circle(vel[0], vel[1], rcx, rcy, r_tau, pts, dirs, n)  # right cut-off
            n += 1
            continue

        inf = math.inf
        if t < 0.0 or t > 1.0 or same:
            d_cut = inf
        else:
            qx, qy = vel[0] - (lcx + t * cvx), vel[1] - (lcy + t * cvy)
            d_cut = qx * qx + qy * qy
        if t_left < 0.0:
            d_left = inf
        else:
            qx, qy = vel[0] - (lcx + t_left * llx), vel[1] - (lcy + t_left * lly)
            d_left = qx * qx + qy * qy
        if t_right < 0.0:
            d_right = inf
        else:
            qx, qy = vel[0] - (rcx + t_right * rlx), vel[1] - (rcy + t_right * rly)
            d_right = qx * qx + qy * qy

        if d_cut <= d_left and d_cut <= d_right:       # the cut-off line (the wall itself)
            _offset_line(lcx, lcy, -o1dx, -o1dy, r_tau, pts, dirs, n)
            n += 1
        elif d_left <= d_right:
            if left_foreign:
                continue
            _offset_line(lcx, lcy, llx, lly, r_tau, pts, dirs, n)       # left leg
            n += 1
        else:
            if right_foreign:
                continue
            _offset_line(rcx, rcy, -rlx, -rly, r_tau, pts, dirs, n)     # right leg
            n += 1
    return n


@njit(cache=True)
def agent_orca_lines(pos: np.ndarray, vel: np.ndarray, radius: float, tau: float,
                     dt: float, others_pos: np.ndarray, others_vel: np.ndarray,
                     others_radius: np.ndarray, pts: np.ndarray, dirs: np.ndarray,
                     n: int) -> int:
    """Append reciprocal ORCA lines for the other agents (each takes half the change).

    Agents already overlapping are pushed apart within one step ``dt`` [s].
    Returns the new number of lines.
    """
    inv_tau = 1.0 / tau
    for i in range(others_pos.shape[0]):
        rpx, rpy = others_pos[i, 0] - pos[0], others_pos[i, 1] - pos[1]
        rvx, rvy = vel[0] - others_vel[i, 0], vel[1] - others_vel[i, 1]
        dist2 = rpx * rpx + rpy * rpy
        comb = radius + others_radius[i]
        comb2 = comb * comb
        if dist2 > comb2:
            wx, wy = rvx - inv_tau * rpx, rvy - inv_tau * rpy
            wl2 = wx * wx + wy * wy
            dot = wx * rpx + wy * rpy
            if dot < 0.0 and dot * dot > comb2 * wl2:
                wl = math.sqrt(wl2)
                ux, uy = wx / wl, wy / wl
                ldx, ldy = uy, -ux
                ux, uy = (comb * inv_tau - wl) * ux, (comb * inv_tau - wl) * uy
            else:
                llx, lly, rlx, rly = _tangent_legs(rpx, rpy, dist2, comb, comb2)
                if _det(rpx, rpy, wx, wy) > 0.0:
                    ldx, ldy = llx, lly                     # project on the left leg
                else:
                    ldx, ldy = -rlx, -rly                   # on the right leg
                dp = rvx * ldx + rvy * ldy
                ux, uy = dp * ldx - rvx, dp * ldy - rvy
        else:
            inv_dt = 1.0 / dt
            wx, wy = rvx - inv_dt * rpx, rvy - inv_dt * rpy
            wl = math.sqrt(wx * wx + wy * wy)
            if wl == 0.0:
                continue
            ux, uy = wx / wl, wy / wl
            ldx, ldy = uy, -ux
            ux, uy = (comb * inv_dt - wl) * ux, (comb * inv_dt - wl) * uy
        dirs[n, 0], dirs[n, 1] = ldx, ldy
        pts[n, 0], pts[n, 1] = vel[0] + 0.5 * ux, vel[1] + 0.5 * uy
        n += 1
    return n


@njit(cache=True)
def _lp1(pts, dirs, line_no, radius, opt, direction_opt, result) -> bool:
    """Optimum on line ``line_no`` subject to the earlier lines and the speed disc."""
    dot = pts[line_no, 0] * dirs[line_no, 0] + pts[line_no, 1] * dirs[line_no, 1]
    disc = dot * dot + radius * radius - (pts[line_no, 0] ** 2 + pts[line_no, 1] ** 2)
    if disc < 0.0:
        return False
    sq = math.sqrt(disc)
    t_left = -dot - sq
    t_right = -dot + sq
    for i in range(line_no):
        denom = _det(dirs[line_no, 0], dirs[line_no, 1], dirs[i, 0], dirs[i, 1])
        numer = _det(dirs[i, 0], dirs[i, 1],
                     pts[line_no, 0] - pts[i, 0], pts[line_no, 1] - pts[i, 1])
        if abs(denom) <= EPS:
            if numer < 0.0:
                return False
            continue
        t = numer / denom
        if denom >= 0.0:
            t_right = min(t_right, t)
        else:
            t_left = max(t_left, t)
        if t_left > t_right:
            return False
    if direction_opt:
        if opt[0] * dirs[line_no, 0] + opt[1] * dirs[line_no, 1] > 0.0:
            t = t_right
        else:
            t = t_left
    else:
        t = (dirs[line_no, 0] * (opt[0] - pts[line_no, 0])
             + dirs[line_no, 1] * (opt[1] - pts[line_no, 1]))
        t = min(max(t, t_left), t_right)
    result[0] = pts[line_no, 0] + t * dirs[line_no, 0]
    result[1] = pts[line_no, 1] + t * dirs[line_no, 1]
    return True


@njit(cache=True)
def _lp2(pts, dirs, n, radius, opt, direction_opt, result) -> int:
    """Closest point to ``opt`` (or farthest along it) meeting all ``n`` lines.

    Returns ``n`` on success, else the index of the line that made it infeasible.
    """
    if direction_opt:
        result[0], result[1] = opt[0] * radius, opt[1] * radius
    else:
        o2 = opt[0] * opt[0] + opt[1] * opt[1]
        if o2 > radius * radius:
            s = radius / math.sqrt(o2)
            result[0], result[1] = opt[0] * s, opt[1] * s
        else:
            result[0], result[1] = opt[0], opt[1]
    keep = np.empty(2)
    for i in range(n):
        if _det(dirs[i, 0], dirs[i, 1], pts[i, 0] - result[0], pts[i, 1] - result[1]) > 0.0:
            keep[0], keep[1] = result[0], result[1]
            if not _lp1(pts, dirs, i, radius, opt, direction_opt, result):
                result[0], result[1] = keep[0], keep[1]
                return i
    return n


@njit(cache=True)
def _lp3(pts, dirs, n, n_obst, begin, radius, result) -> None:
    """Least-violating velocity when no velocity meets every line (agents overlapping).

    Obstacle lines stay hard; agent lines are relaxed equally (RVO2's 3-D LP).
    """
    distance = 0.0
    proj_pts = np.empty((n, 2))
    proj_dirs = np.empty((n, 2))
    opt = np.empty(2)
    keep = np.empty(2)
    for i in range(begin, n):
        if _det(dirs[i, 0], dirs[i, 1], pts[i, 0] - result[0], pts[i, 1] - result[1]) > distance:
            m = 0
            for j in range(n_obst):
                proj_pts[m, 0], proj_pts[m, 1] = pts[j, 0], pts[j, 1]
                proj_dirs[m, 0], proj_dirs[m, 1] = dirs[j, 0], dirs[j, 1]
                m += 1
            for j in range(n_obst, i):
                det = _det(dirs[i, 0], dirs[i, 1], dirs[j, 0], dirs[j, 1])
                if abs(det) <= EPS:
                    if dirs[i, 0] * dirs[j, 0] + dirs[i, 1] * dirs[j, 1] > 0.0:
                        continue
                    px = 0.5 * (pts[i, 0] + pts[j, 0])
                    py = 0.5 * (pts[i, 1] + pts[j, 1])
                else:
                    f = _det(dirs[j, 0], dirs[j, 1],
                             pts[i, 0] - pts[j, 0], pts[i, 1] - pts[j, 1]) / det
                    px = pts[i, 0] + f * dirs[i, 0]
                    py = pts[i, 1] + f * dirs[i, 1]
                qx, qy = dirs[j, 0] - dirs[i, 0], dirs[j, 1] - dirs[i, 1]
                ql = math.sqrt(qx * qx + qy * qy)
                proj_pts[m, 0], proj_pts[m, 1] = px, py
                proj_dirs[m, 0], proj_dirs[m, 1] = qx / ql, qy / ql
                m += 1
            keep[0], keep[1] = result[0], result[1]
            opt[0], opt[1] = -dirs[i, 1], dirs[i, 0]
            if _lp2(proj_pts, proj_dirs, m, radius, opt, True, result) < m:
                result[0], result[1] = keep[0], keep[1]
            distance = _det(dirs[i, 0], dirs[i, 1], pts[i, 0] - result[0], pts[i, 1] - result[1])


@njit(cache=True)
def solve_velocity(pts: np.ndarray, dirs: np.ndarray, n: int, n_obst: int,
                   max_speed: float, pref: np.ndarray, out: np.ndarray) -> bool:
    """The permitted velocity closest to ``pref`` within ``max_speed`` [m/s] (eq. 6).

    Writes it to ``out`` (2,). Returns False when the lines had no common point
    and the least-violating velocity was taken instead.
    """
    fail = _lp2(pts, dirs, n, max_speed, pref, False, out)
    if fail < n:
        _lp3(pts, dirs, n, n_obst, fail, max_speed, out)
        return False
    return True


@njit(cache=True)
def smallest_rotation(vel: np.ndarray, pts: np.ndarray, dirs: np.ndarray, n: int) -> float:
    """Smallest signed rotation [rad] that brings ``vel`` into every ORCA half-plane.

    This is the paper's correction angle theta_i (§2.2, Figure 4): the INS velocity
    *rotated* until it avoids the obstacles, its speed kept. On the circle of radius
    ``|vel|`` each line permits one arc; the answer is the permitted angle nearest the
    INS heading (candidates: no rotation and every arc end). NaN when no velocity of
    that speed is permitted (the agent is boxed in).
    """
    s = math.sqrt(vel[0] * vel[0] + vel[1] * vel[1])
    if s == 0.0:
        return 0.0
    phi0 = math.atan2(vel[1], vel[0])
    best = math.nan
    for k in range(2 * n + 1):
        if k == 0:
            theta = 0.0
        else:
            i = (k - 1) // 2
            c = _det(dirs[i, 0], dirs[i, 1], pts[i, 0], pts[i, 1]) / s
            if c > 1.0:
                return math.nan          # this line forbids every velocity of this speed
            if c < -1.0:
                continue                  # this line forbids none
            psi = math.atan2(dirs[i, 1], dirs[i, 0])
            a = math.asin(c)
            end = psi + a if (k - 1) % 2 == 0 else psi + math.pi - a
            theta = (end - phi0 + math.pi) % (2.0 * math.pi) - math.pi
        if not math.isnan(best) and abs(theta) >= abs(best):
            continue
        ux, uy = s * math.cos(phi0 + theta), s * math.sin(phi0 + theta)
        ok = True
        for j in range(n):
            if _det(dirs[j, 0], dirs[j, 1], pts[j, 0] - ux, pts[j, 1] - uy) > EPS * s:
                ok = False
                break
        if ok:
            best = theta
    return best
