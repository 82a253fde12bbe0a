"""Evaluation against sparse ground truth: surveyed checkpoints.

Real datasets rarely have truth at every instant: the indoor walks of
``../shared/data`` have one surveyed footprint per stride, the ORCA paper's tests five
to twelve marked stop points (Sec. 3.2, Table 1). Here the *estimate* is interpolated
linearly to each checkpoint time (checkpoints outside the estimate's time span are
left out and counted) and compared with the checkpoint position.

Alignment, for estimates whose frame is not the building's (a bare INS: its yaw and
origin are arbitrary), always stated with the result:

* ``none``: the estimate is already in the truth's frame;
* ``first:K``: a 2D rotation and translation fitted (least squares) on the first K
  checkpoints only — what a live system could know, honest (K = 1: translation only);
* ``first:Dm``: the same on the checkpoints of the first D metres of the truth's path
  (at least two), for dense truth (a VICON capture at 20 Hz) where K samples are a blink;
* ``all``: fitted on every checkpoint — the best possible alignment, optimistic.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..tracks import Track
from .metrics import TrackErrors, floor_right, path_length


@dataclass
class Checkpoints:
    """Sparse truth of one agent: ``t`` (K,) [s], ``position`` (K, 3) [m], ``floor`` (K,)
    (-1 unknown) and optional ``names``."""

    agent: str
    t: np.ndarray
    position: np.ndarray
    floor: np.ndarray
    names: list[str] | None = None

    @classmethod
    def from_track(cls, truth: Track) -> "Checkpoints":
        return cls(truth.agent, truth.t.copy(), truth.position.copy(), truth.floor.copy())

    def __len__(self) -> int:
        return len(self.t)


def parse_align(align: str) -> tuple[str, float]:
    """``"none"`` / ``"all"`` / ``"first:K"`` / ``"first:Dm"`` -> (mode, K or D);
    ValueError otherwise (mode ``"metres"`` for ``first:Dm``)."""
    if align in ("none", "all"):
        return align, 0
    if align.startswith("first"):
        _, _, k = align.partition(":")
        if k.endswith("m"):
            try:
                d = float(k[:-1])
            except ValueError:
                d = 0.0
            if d > 0:
                return "metres", d
        try:
            n = int(k) if k else 2
        except ValueError:
            n = 0
        if n >= 1:
            return "first", n
    raise ValueError(f"alignment '{align}' must be none, all or first:K (K >= 1 checkpoints), "
                     "or first:Dm (the first D metres)")


def fit_rigid_2d(src: np.ndarray, dst: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotation (2, 2) and translation (2,) minimising |R src + t - dst|^2 (Kabsch).

    With one point pair only the translation is fitted.
    """
    src, dst = np.asarray(src, float), np.asarray(dst, float)
    if len(src) == 1:
        return np.eye(2), dst[0] - src[0]
    cs, cd = src.mean(axis=0), dst.mean(axis=0)
    h = (src - cs).T @ (dst - cd)
    u, _, vt = np.linalg.svd(h)
    d = np.sign(np.linalg.det(vt.T @ u.T)) or 1.0
    r = vt.T @ np.diag([1.0, d]) @ u.T
    return r, cd - r @ cs


def estimate_at(track: Track, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(positions (K, 3), floors (K,), inside mask) of ``track`` at times ``t``."""
    t = np.asarray(t, float)
    if len(track) == 0:
        return np.full((len(t), 3), np.nan), np.full(len(t), -1), np.zeros(len(t), bool)
    inside = (t >= track.t[0]) & (t <= track.t[-1])
    pos = np.column_stack([np.interp(t, track.t, track.position[:, i]) for i in range(3)])
    idx = np.clip(np.searchsorted(track.t, t, side="right") - 1, 0, len(track) - 1)
    return pos, track.floor[idx], inside


def checkpoint_errors(track: Track, cps: Checkpoints, *, align: str = "none",
                      distance_m: float | None = None) -> tuple[TrackErrors, int]:
    """Errors at the checkpoints (and how many fell outside the estimate's span).

    ``distance_m``: the true distance travelled if known (else the length of the
    polyline through the checkpoints, a lower bound).
    """
    mode, k = parse_align(align)
    pos, floor, inside = estimate_at(track, cps.t)
    t = cps.t[inside]
    est = pos[inside]
    ref = cps.position[inside]
    if mode != "none" and len(t):
        if mode == "metres":
            walked = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(ref[:, :2], axis=0).T))))
            n = max(2, int(np.searchsorted(walked, k, side="right")))
        else:
            n = len(t) if mode == "all" else int(min(k, len(t)))
        r, off = fit_rigid_2d(est[:n, :2], ref[:n, :2])
        est = est.copy()
        est[:, :2] = est[:, :2] @ r.T + off
    horizontal = np.hypot(*(est[:, :2] - ref[:, :2]).T) if len(t) else np.empty(0)
    vertical = est[:, 2] - ref[:, 2] if len(t) else np.empty(0)
    floor_ok = floor_right(floor[inside], cps.floor[inside], ref[:, 2], None)
    dist = distance_m if distance_m is not None else path_length(cps.position[:, :2])
    return (TrackErrors(cps.agent, t, horizontal, vertical, floor_ok, dist),
            int((~inside).sum()))


def is_sparse(truth: Track, spacing_s: float = 0.25) -> bool:
    """True when the truth is checkpoint-like (median spacing above ``spacing_s``)."""
    return len(truth) < 3 or float(np.median(np.diff(truth.t))) > spacing_s
