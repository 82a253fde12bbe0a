"""Drawing a floor of a building on matplotlib axes, and PNGs of every floor."""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import shapely

from .model import Building

__all__ = ["draw_floor", "save_floor_images"]

_ROOM_COLOURS = {"corridor": "#eef3f8", "hall": "#eef3f8", "stairwell": "#f4efe6"}


def _fill(ax: Any, geom, **kw) -> None:
    from matplotlib.patches import PathPatch
    from matplotlib.path import Path as MplPath
    for poly in shapely.get_parts(geom):
        if poly.is_empty or poly.geom_type != "Polygon":
            continue
        rings = [np.asarray(poly.exterior.coords)] + [np.asarray(r.coords) for r in poly.interiors]
        verts = np.concatenate(rings)
        codes = np.concatenate([[MplPath.MOVETO] + [MplPath.LINETO] * (len(r) - 2) + [MplPath.CLOSEPOLY]
                                for r in rings])
        ax.add_patch(PathPatch(MplPath(verts, codes), **kw))


def draw_floor(ax: Any, building: Building, floor_index: int, *, patterns: Any = None,
               labels: bool = False) -> None:
    """Draw rooms, walls, obstacles, doors, openings, stairs, anchors and entrances of one
    floor on ``ax`` (plan metres, equal aspect).

    ``patterns``: search patterns to overlay, either an object with
    ``draw(ax, floor)`` (:class:`~.search_patterns.SearchPatterns`) or a list of node
    sequences, each (N, 2) [m]. ``labels`` writes room names.
    """
    floor = building.floor(floor_index)
    for room in floor.rooms:
        _fill(ax, room.polygon, facecolor=_ROOM_COLOURS.get(room.use, "#fafafa"),
              edgecolor="none", zorder=0)
        if labels:
            c = room.polygon.representative_point()
            ax.text(c.x, c.y, room.name or room.id, fontsize=5, ha="center", va="center",
                    color="#777777", zorder=1)
    for obst in floor.obstacles:
        _fill(ax, obst.polygon, facecolor="#c8c8c8", edgecolor="#888888", lw=0.5, zorder=2)
    for stair in floor.stairs:
        _fill(ax, stair.polygon, facecolor="none", edgecolor="#a0522d", hatch="---", lw=0.6, zorder=2)
        ax.annotate("", xy=stair.top, xytext=stair.path[-2], zorder=3,
                    arrowprops=dict(arrowstyle="->", color="#a0522d", lw=0.8))
        ax.plot(*stair.path[:-1].T, color="#a0522d", lw=0.8, zorder=3)
    for stair in building.stairs:
        if stair.floor_to == floor_index:
            _fill(ax, stair.polygon, facecolor="none", edgecolor="#a0522d", hatch="..",
                  lw=0.4, ls=":", zorder=2)
    walls = floor.walls[~floor.wall_is_obstacle]
    if len(walls):
        from matplotlib.collections import LineCollection
        ax.add_collection(LineCollection(walls, colors="k", linewidths=1.6, zorder=4))
    for gap in floor.doors + floor.openings:
        j = gap.jambs
        door = gap.kind == "door"
        ax.plot(*j.T, color="#1f77b4" if door else "#2ca02c", lw=1.0, ls="-" if door else "--",
                zorder=5)
        tip = gap.center + 0.35 * gap.axis
        ax.annotate("", xy=tip, xytext=gap.center - 0.35 * gap.axis, zorder=5,
                    arrowprops=dict(arrowstyle="<->", color="#1f77b4" if door else "#2ca02c", lw=0.6))
    for a in building.anchors:
        if a.floor == floor_index:
            ax.plot(a.position[0], a.position[1], marker="^", color="#d62728", ms=7, zorder=6)
            ax.annotate(a.id, a.position[:2], textcoords="offset points", xytext=(4, 4),
                        fontsize=6, color="#d62728")
    for e in building.entrances:
        if e.floor == floor_index:
            d = np.array([np.cos(e.heading), np.sin(e.heading)])
            ax.annotate("", xy=e.position + 1.2 * d, xytext=e.position - 1.2 * d, zorder=6,
                        arrowprops=dict(arrowstyle="-|>", color="#9467bd", lw=1.5))
    if hasattr(patterns, "draw"):
        patterns.draw(ax, floor_index)
    else:
        for seq in patterns or []:
            seq = np.asarray(seq, dtype=float).reshape(-1, 2)
            ax.plot(seq[:, 0], seq[:, 1], "-o", color="#ff7f0e", ms=2.5, lw=0.6, alpha=0.8, zorder=7)
    x0, y0, x1, y1 = floor.outline.bounds if not floor.outline.is_empty else (0, 0, 1, 1)
    pts = [a.position[:2] for a in building.anchors if a.floor == floor_index]
    if pts:
        p = np.array(pts)
        x0, y0 = min(x0, p[:, 0].min()), min(y0, p[:, 1].min())
        x1, y1 = max(x1, p[:, 0].max()), max(y1, p[:, 1].max())
    ax.set_xlim(x0 - 1.5, x1 + 1.5)
    ax.set_ylim(y0 - 1.5, y1 + 1.5)
    ax.set_aspect("equal")


def save_floor_images(building: Building, out_dir: str | Path, *, patterns: Any = None,
                      dpi: int = 150) -> list[Path]:
    """Write ``<out_dir>/<building>_floor<i>.png`` for every floor; returns the paths.

    ``patterns`` as for :func:`draw_floor` (a SearchPatterns object covers all floors).
    """
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for floor in building.floors:
        x0, y0, x1, y1 = floor.outline.bounds if not floor.outline.is_empty else (0, 0, 10, 10)
        w = max(x1 - x0, 1.0)
        h = max(y1 - y0, 1.0)
        fig, ax = plt.subplots(figsize=(min(16, 3 + 10 * w / max(w, h)), min(16, 3 + 10 * h / max(w, h))))
        draw_floor(ax, building, floor.index, labels=True, patterns=patterns)
        ax.set_title(f"{building.name}: floor {floor.index} ({floor.name}), z = {floor.z:g} m")
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        ax.grid(alpha=0.25, lw=0.5)
        fig.tight_layout()
        path = out / f"{building.name}_floor{floor.index}.png"
        fig.savefig(path, dpi=dpi)
        plt.close(fig)
        paths.append(path)
    return paths
