"""Walls drawn twice: finding collinear overlapping wall segments, and merging them.

Exports draw a wall once per room it bounds (Aamks writes the shared wall of two
rooms twice, and butt-joined collinear walls overlap by their thickness), CAD drawings
often carry a wall on two layers. :func:`overlapping_pairs` finds segments that lie on
one line (every end within ``tol`` of the other's line) and share more than ``tol`` of
their length; ``map check`` reports them in native plans, and importers merge them with
:func:`merge_overlapping` (each group becomes one segment over the union of the group).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
import shapely

__all__ = ["Overlap", "overlapping_pairs", "merge_overlapping"]


class Overlap(NamedTuple):
    """Segments ``i`` < ``j`` overlap for ``length`` [m] around plan point ``mid`` (2,)."""

    i: int
    j: int
    length: float
    mid: np.ndarray


def overlapping_pairs(segs: np.ndarray, tol: float) -> list[Overlap]:
    """Every pair of segments (W, 2, 2) [m] on one line (within ``tol`` [m]) that share
    more than ``tol`` of their length, in index order."""
    segs = np.asarray(segs, float).reshape(-1, 2, 2)
    if len(segs) < 2:
        return []
    lines = shapely.linestrings(segs)
    a, b = shapely.STRtree(lines).query(lines, predicate="dwithin", distance=tol)
    keep = a < b
    out = []
    for i, j in zip(a[keep], b[keep]):
        got = _overlap(segs[i], segs[j], tol)
        if got is not None:
            out.append(Overlap(int(i), int(j), *got))
    return out


def _overlap(p: np.ndarray, q: np.ndarray, tol: float) -> tuple[float, np.ndarray] | None:
    """(shared length, its middle) of segment q on segment p's line, or None."""
    u = p[1] - p[0]
    length = float(np.hypot(*u))
    if length <= 0:
        return None
    u = u / length
    rel = q - p[0]
    off = np.abs(rel[:, 0] * u[1] - rel[:, 1] * u[0])     # q's ends from p's line
    if off.max() > tol:
        return None
    s = rel @ u
    lo, hi = max(0.0, float(s.min())), min(length, float(s.max()))
    if hi - lo <= tol:
        return None
    return hi - lo, p[0] + u * (lo + hi) / 2


def merge_overlapping(segs: np.ndarray, ids: list[str], tol: float
                      ) -> tuple[np.ndarray, list[str], list[tuple[str, list[str], np.ndarray]]]:
    """Replace each group of overlapping segments by one segment over their union.

    The merged segment lies on the line of the group's longest segment and keeps its
    id. Returns (segments (W', 2, 2), ids, merges): one ``(kept id, merged ids, plan
    point)`` per group, for the import notes.
    """
    segs = np.asarray(segs, float).reshape(-1, 2, 2)
    pairs = overlapping_pairs(segs, tol)
    if not pairs:
        return segs, list(ids), []
    parent = list(range(len(segs)))

    def root(k: int) -> int:
        while parent[k] != k:
            parent[k] = parent[parent[k]]
            k = parent[k]
        return k

    for o in pairs:
        parent[root(o.j)] = root(o.i)
    groups: dict[int, list[int]] = {}
    for k in range(len(segs)):
        groups.setdefault(root(k), []).append(k)
    lengths = np.linalg.norm(segs[:, 1] - segs[:, 0], axis=1)
    out_segs, out_ids, merges = [], [], []
    for members in groups.values():          # in order of each group's first segment
        if len(members) == 1:
            out_segs.append(segs[members[0]])
            out_ids.append(ids[members[0]])
            continue
        best = max(members, key=lambda k: lengths[k])
        p0 = segs[best, 0]
        u = (segs[best, 1] - p0) / lengths[best]
        s = (segs[members].reshape(-1, 2) - p0) @ u
        merged = np.array([p0 + u * s.min(), p0 + u * s.max()])
        out_segs.append(merged)
        out_ids.append(ids[best])
        others = sorted({ids[k] for k in members if k != best} - {ids[best]})
        merges.append((ids[best], others, merged.mean(axis=0)))
    return np.array(out_segs).reshape(-1, 2, 2), out_ids, merges
