"""Synthetic walks with drifting odometry, for particle-filter tests without the simulator.

A firefighter walks a given building-frame path in strides; the "INS" sees it in its
own frame (rotated by an arbitrary yaw), with a step-length scale error, a heading
drift that grows with time, a fixed IMU-yaw-to-walking-direction offset and small
per-stride noise. The output is the list of :class:`Odometry` messages the ZUPT INS
would publish (one per stride) and the true poses at the same times.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from firenav_framework import GroundTruth, Odometry


@dataclass
class Walk:
    odometry: list[Odometry]
    truth: list[GroundTruth]

    @property
    def truth_xy(self) -> np.ndarray:
        return np.array([g.position[:2] for g in self.truth])

    def messages(self) -> list[tuple[str, object]]:
        """Truth and odometry interleaved in time order, as (stream, message)."""
        out = [("truth", g) for g in self.truth] + [("odo", o) for o in self.odometry]
        return sorted(out, key=lambda sm: (sm[1].t, sm[0] == "odo"))


def resample_path(path: np.ndarray, stride: float) -> np.ndarray:
    """Points every ``stride`` metres along a polyline (N, 2), keeping the last point."""
    d = np.hypot(*np.diff(path, axis=0).T)
    s = np.concatenate([[0.0], np.cumsum(d)])
    t = np.append(np.arange(0.0, s[-1], stride), s[-1])
    return np.column_stack([np.interp(t, s, path[:, 0]), np.interp(t, s, path[:, 1])])


def drifting_walk(path: np.ndarray, *, stride: float = 0.7, step_time: float = 1.2,
                  ins_yaw: float = 1.0, scale: float = 1.02, drift_deg_per_min: float = 3.0,
                  mount_offset_deg: float = 6.0, noise_m: float = 0.02, seed: int = 0,
                  agent: str = "ff1", t0: float = 0.0) -> Walk:
    """Odometry for walking ``path`` (N, 2) [m] with the given error model."""
    rng = np.random.default_rng(seed)
    xy = resample_path(np.asarray(path, float), stride)
    t = t0 + np.arange(len(xy)) * step_time
    d = np.diff(xy, axis=0)
    walk_dir = np.arctan2(d[:, 1], d[:, 0])
    walk_dir = np.append(walk_dir[:1], walk_dir)  # heading at each pose (first = first leg)
    drift = np.radians(drift_deg_per_min) * (t - t0) / 60.0
    ins_pos = np.zeros((len(xy), 3))
    for k in range(1, len(xy)):
        step_len = np.hypot(*d[k - 1]) * scale + rng.normal(0, noise_m)
        ang = walk_dir[k] + ins_yaw + drift[k]
        ins_pos[k, :2] = ins_pos[k - 1, :2] + step_len * np.array([np.cos(ang), np.sin(ang)])
    ins_heading = walk_dir + ins_yaw + drift + np.radians(mount_offset_deg)
    odo = []
    for k in range(1, len(xy)):
        odo.append(Odometry(t=float(t[k]), agent=agent, device=f"{agent}/imu",
                            t_start=float(t[k - 1]), delta=ins_pos[k] - ins_pos[k - 1],
                            dheading=float(ins_heading[k] - ins_heading[k - 1]),
                            cov=np.diag([1e-4, 1e-4, 1e-4, 1e-4]), position=ins_pos[k].copy(),
                            heading=float(np.angle(np.exp(1j * ins_heading[k])))))
    truth = [GroundTruth(t=float(t[k]), agent=agent, position=np.array([*xy[k], 0.0]),
                         heading=float(walk_dir[k]), floor=0) for k in range(len(xy))]
    return Walk(odo, truth)
