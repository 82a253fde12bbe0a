"""Synthetic foot-INS strides and tag passes along known paths of the three-storey plan.

The truth is a polyline walked in strides of about ``stride`` metres, one every
``period`` seconds. The INS odometry of those strides is expressed in an INS frame
turned by ``yaw`` (its yaw origin is arbitrary), with a heading error that is a constant
``bias`` plus a drift ``rate`` [rad/s], a step-length ``scale`` and optional noise; the
foot (IMU x axis) points along the stride, or against it when walking backwards.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from firenav_framework import Odometry, TagDeployment, TagDetection, Tick

ODO_COV = np.diag([1e-4, 1e-4, 1e-4, 1e-6])


@dataclass
class Walk:
    """Stride ends of a walk: times (N+1,) [s], positions (N+1, 3) [m], and per stride
    whether the person walked backwards (N,)."""

    t: np.ndarray
    p: np.ndarray
    backwards: np.ndarray

    def at(self, t: float) -> np.ndarray:
        return np.array([np.interp(t, self.t, self.p[:, k]) for k in range(3)])


def walk(points, stride: float = 1.3, period: float = 1.1, t0: float = 10.0,
         backwards: bool = False) -> Walk:
    """Strides along the polyline ``points`` (K, 2) or (K, 3) [m]; each leg is cut into
    whole strides of about ``stride`` metres (horizontal, or 3-D length on a flat leg)."""
    pts = np.asarray(points, float)
    if pts.shape[1] == 2:
        pts = np.column_stack([pts, np.zeros(len(pts))])
    out = [pts[0]]
    for a, b in zip(pts[:-1], pts[1:]):
        n = max(1, round(float(np.hypot(*(b - a)[:2])) / stride))
        out += [a + (b - a) * (k / n) for k in range(1, n + 1)]
    p = np.array(out)
    t = t0 + period * np.arange(len(p))
    return Walk(t, p, np.full(len(p) - 1, backwards))


def join(*walks: Walk, pause: float = 0.0) -> Walk:
    """Walks one after the other, each starting where and ``pause`` seconds after the
    previous one ended (its first point is the previous one's last)."""
    t, p, b = [walks[0].t], [walks[0].p], [walks[0].backwards]
    for w in walks[1:]:
        t.append(w.t[1:] - w.t[0] + t[-1][-1] + pause)
        p.append(w.p[1:])
        b.append(w.backwards)
    return Walk(np.concatenate(t), np.concatenate(p), np.concatenate(b))


def odometry(w: Walk, *, agent: str = "ff1", yaw: float = -2.0, bias: float = 0.0,
             rate: float = 0.0, scale: float = 1.0, noise: float = 0.0, dz_noise: float = 0.0,
             gradient: tuple[float, float] = (0.0, 0.0), labels: bool = False,
             rng=None) -> list[Odometry]:
    """INS odometry of the strides of ``w`` (module docstring). ``gradient`` (2,) [m/m]:
    the INS's vertical drift per metre walked along the INS frame's x and y. ``labels``:
    set the ``motion`` labels a perfect INS gait classifier would give."""
    rng = rng or np.random.default_rng(0)
    out, pos = [], np.zeros(3)
    prev_heading = None
    for k in range(len(w.t) - 1):
        d = w.p[k + 1] - w.p[k]
        err = bias + rate * (w.t[k + 1] - w.t[0])
        ang = yaw + err
        c, s = math.cos(ang), math.sin(ang)
        dx, dy = d[0] * scale, d[1] * scale
        delta = np.array([c * dx - s * dy, s * dx + c * dy, d[2]])
        if noise:
            delta[:2] += rng.normal(0, noise, 2)
        delta[2] += float(np.dot(gradient, delta[:2])) + (rng.normal(0, dz_noise) if dz_noise else 0.0)
        move = math.atan2(delta[1], delta[0]) if np.hypot(*d[:2]) > 1e-9 else (prev_heading or 0.0)
        heading = move + (math.pi if w.backwards[k] else 0.0)
        heading = math.remainder(heading, 2 * math.pi)
        dheading = 0.0 if prev_heading is None else math.remainder(heading - prev_heading, 2 * math.pi)
        pos = pos + delta
        motion = ""
        if labels:
            motion = ("walk" if abs(d[2]) < 0.05 else "stairs_up" if d[2] > 0 else
                      "stairs_down_backward" if w.backwards[k] else "stairs_down")
        out.append(Odometry(t=float(w.t[k + 1]), agent=agent, device=f"{agent}/imu",
                            t_start=float(w.t[k]), delta=delta, dheading=dheading,
                            cov=ODO_COV, position=pos.copy(), heading=heading, motion=motion))
        prev_heading = heading
    return out


def closest_passes(w: Walk, sites: dict[str, np.ndarray], radius: float = 0.8,
                   dt: float = 0.05) -> list[tuple[float, str]]:
    """(time of closest approach, site id) each time the walk comes within ``radius`` [m]
    of a site (2,) or (3,) (horizontal distance; same floor within 1.5 m of height)."""
    ts = np.arange(w.t[0], w.t[-1], dt)
    xyz = np.array([w.at(t) for t in ts])
    out = []
    for sid, pos in sites.items():
        pos = np.asarray(pos, float)
        d = np.hypot(xyz[:, 0] - pos[0], xyz[:, 1] - pos[1])
        if len(pos) == 3:
            d = np.where(np.abs(xyz[:, 2] - pos[2]) < 1.5, d, np.inf)
        inside = d < radius
        edges = np.flatnonzero(np.diff(np.concatenate([[0], inside.astype(int), [0]])))
        for a, b in zip(edges[::2], edges[1::2]):
            k = a + int(np.argmin(d[a:b]))
            out.append((float(ts[k]), sid))
    return sorted(out)


def detections(passes, tag_of: dict[str, str], agent: str = "ff1") -> list[TagDetection]:
    return [TagDetection(t=t, agent=agent, device=f"{agent}/rfid", tag_id=tag_of[s],
                         reader=f"{agent}/rfid", rssi_dbm=-45.0, reads=5)
            for t, s in passes if s in tag_of]


def deployments(passes, tag_of: dict[str, str], agent: str = "ff1") -> list[TagDeployment]:
    seen, out = set(), []
    for t, s in passes:
        if s in tag_of and s not in seen:
            seen.add(s)
            out.append(TagDeployment(t=t, agent=agent, device=f"{agent}/rfid", tag_id=tag_of[s]))
    return out


def feed(component, messages, period: float = 1.0) -> None:
    """Give ``messages`` to a component in time order with ``Tick`` messages every
    ``period`` seconds (as the runner's timeline would), then finish it."""
    msgs = sorted(messages, key=lambda m: m.t)
    if not msgs:
        component.finish()
        return
    k = math.ceil(msgs[0].t / period)
    for m in msgs:
        while k * period <= m.t:
            component.handle("ticks", Tick(t=k * period, period=period))
            k += 1
        component.handle("in", m)
    component.handle("ticks", Tick(t=k * period, period=period))
    component.finish()


def track_errors(poses, truth: Walk, agent: str = "ff1") -> np.ndarray:
    """Horizontal errors [m] of an agent's poses against the walk."""
    ps = [p for p in poses if p.agent == agent]
    return np.array([np.hypot(*(p.position[:2] - truth.at(p.t)[:2])) for p in ps])
