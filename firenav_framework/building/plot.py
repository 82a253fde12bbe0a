"""Drawing a floor of a building on matplotlib axes, and PNGs of every floor.

:func:`draw_floor` draws the plan (rooms, walls, obstacles, doors, openings, stairs,
anchors, entrances); with ``labels`` it writes every feature's id and room names, so
a commander or an integrator can find a door, an entrance or a stair by its id.
:func:`scale_bar` and :func:`north_arrow` add the map furniture; :func:`save_floor_images`
(``firenav map show``) writes one labelled PNG per floor with both.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import shapely

from .model import Building

__all__ = ["draw_floor", "scale_bar", "north_arrow", "save_floor_images"]

_ROOM_COLOURS = {"corridor": "#eef3f8", "hall": "#eef3f8", "stairwell": "#f4efe6"}
_STAIR = "#a0522d"
_DOOR, _OPENING, _ENTRANCE, _ANCHOR = "#1f77b4", "#2ca02c", "#9467bd", "#d62728"


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


def _label(ax: Any, text: str, xy, colour: str, size: float = 5.0, **kw) -> None:
    ax.annotate(text, xy=(float(xy[0]), float(xy[1])), fontsize=size, color=colour, zorder=8,
                ha=kw.pop("ha", "center"), va=kw.pop("va", "center"),
                bbox=dict(boxstyle="round,pad=0.15", fc="white", ec="none", alpha=0.7), **kw)


def draw_floor(ax: Any, building: Building, floor_index: int, *, patterns: Any = None,
               labels: bool = False) -> None:
    """Draw rooms, walls, obstacles, doors, openings, stairs, anchors and entrances of one
    floor on ``ax`` (plan metres, equal aspect).

    ``patterns``: search patterns to overlay, either an object with
    ``draw(ax, floor)`` (:class:`~.search_patterns.SearchPatterns`) or a list of node
    sequences, each (N, 2) [m]. ``labels`` writes room names and the ids of doors,
    openings, stairs (with the floor they lead to), anchors and entrances.
    """
    floor = building.floor(floor_index)
    for room in floor.rooms:
        _fill(ax, room.polygon, facecolor=_ROOM_COLOURS.get(room.use, "#fafafa"),
              edgecolor="none", zorder=0)
        if labels:
            c = room.polygon.representative_point()
            ax.text(c.x, c.y, room.name or room.id, fontsize=6, ha="center", va="center",
                    color="#555555", zorder=1)
    for obst in floor.obstacles:
        _fill(ax, obst.polygon, facecolor="#c8c8c8", edgecolor="#888888", lw=0.5, zorder=2)
    for stair in floor.stairs:
        _fill(ax, stair.polygon, facecolor="none", edgecolor=_STAIR, hatch="---", lw=0.6, zorder=2)
        ax.annotate("", xy=stair.top, xytext=stair.path[-2], zorder=3,
                    arrowprops=dict(arrowstyle="->", color=_STAIR, lw=0.8))
        ax.plot(*stair.path[:-1].T, color=_STAIR, lw=0.8, zorder=3)
        if labels:
            _label(ax, f"{stair.id}\nup to floor {stair.floor_to}", stair.bottom, _STAIR)
    for stair in building.stairs:
        if stair.floor_to == floor_index:
            _fill(ax, stair.polygon, facecolor="none", edgecolor=_STAIR, hatch="..",
                  lw=0.4, ls=":", zorder=2)
            if labels:
                _label(ax, f"{stair.id}\ndown to floor {stair.floor_from}", stair.top, _STAIR)
    walls = floor.walls[~floor.wall_is_obstacle]
    if len(walls):
        from matplotlib.collections import LineCollection
        ax.add_collection(LineCollection(walls, colors="k", linewidths=1.6, zorder=4))
    for gap in floor.doors + floor.openings:
        j = gap.jambs
        colour = _DOOR if gap.kind == "door" else _OPENING
        ax.plot(*j.T, color=colour, lw=1.0, ls="-" if gap.kind == "door" else "--", zorder=5)
        ax.annotate("", xy=gap.center + 0.35 * gap.axis, xytext=gap.center - 0.35 * gap.axis,
                    zorder=5, arrowprops=dict(arrowstyle="<->", color=colour, lw=0.6))
        if labels:
            _label(ax, gap.id, gap.center + 0.6 * gap.axis, colour, size=4.5)
    for a in building.anchors:
        if a.floor == floor_index:
            ax.plot(a.position[0], a.position[1], marker="^", color=_ANCHOR, ms=7, zorder=6)
            ax.annotate(a.id, a.position[:2], textcoords="offset points", xytext=(4, 4),
                        fontsize=6, color=_ANCHOR)
    for e in building.entrances:
        if e.floor == floor_index:
            d = np.array([np.cos(e.heading), np.sin(e.heading)])
            ax.annotate("", xy=e.position + 1.2 * d, xytext=e.position - 1.2 * d, zorder=6,
                        arrowprops=dict(arrowstyle="-|>", color=_ENTRANCE, lw=1.5))
            if labels:
                _label(ax, e.id, e.position - 1.6 * d, _ENTRANCE, size=5.5, weight="bold")
    if hasattr(patterns, "draw"):
        patterns.draw(ax, floor_index)
    else:
        for seq in patterns or []:
            seq = np.asarray(seq, dtype=float).reshape(-1, 2)
            ax.plot(seq[:, 0], seq[:, 1], "-o", color="#ff7f0e", ms=2.5, lw=0.6, alpha=0.8, zorder=7)
    x0, y0, x1, y1 = _extent(building, floor_index)
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal")


def _extent(building: Building, floor_index: int) -> tuple[float, float, float, float]:
    """Plot limits [m]: the floor outline, anchors and entrance arrows, 2.5 m of margin."""
    floor = building.floor(floor_index)
    x0, y0, x1, y1 = floor.outline.bounds if not floor.outline.is_empty else (0, 0, 1, 1)
    pts = [a.position[:2] for a in building.anchors if a.floor == floor_index]
    pts += [e.position for e in building.entrances if e.floor == floor_index]
    if pts:
        p = np.array(pts)
        x0, y0 = min(x0, p[:, 0].min()), min(y0, p[:, 1].min())
        x1, y1 = max(x1, p[:, 0].max()), max(y1, p[:, 1].max())
    return x0 - 2.5, y0 - 2.5, x1 + 2.5, y1 + 2.5


def _nice_length(span: float) -> float:
    """A round length [m] (1, 2 or 5 times a power of ten) about a fifth of ``span``."""
    target = max(span / 5, 1e-3)
    power = 10 ** math.floor(math.log10(target))
    return max(m * power for m in (1, 2, 5) if m * power <= target)


def scale_bar(ax: Any) -> float:
    """Draw a scale bar in the lower left corner of ``ax`` (plan metres); its length [m]."""
    x0, x1 = ax.get_xlim()
    y0, y1 = ax.get_ylim()
    length = _nice_length(x1 - x0)
    bx, by = x0 + 0.04 * (x1 - x0), y0 + 0.04 * (y1 - y0)
    tick = 0.012 * (y1 - y0)
    ax.plot([bx, bx + length], [by, by], color="k", lw=2.5, zorder=9, solid_capstyle="butt")
    ax.plot([bx, bx], [by - tick, by + tick], color="k", lw=1, zorder=9)
    ax.plot([bx + length, bx + length], [by - tick, by + tick], color="k", lw=1, zorder=9)
    ax.text(bx + length / 2, by + 2 * tick, f"{length:g} m", ha="center", va="bottom",
            fontsize=7, zorder=9)
    return length


def north_arrow(ax: Any, building: Building) -> np.ndarray:
    """Draw a north arrow in the upper right corner of ``ax``; the unit vector it points
    along in plan coordinates. True north from the georeference (plan +y turned by its
    bearing); without one, plan +y, labelled as plan north."""
    b = math.radians(building.georef.bearing) if building.georef is not None else 0.0
    north = np.array([-math.sin(b), math.cos(b)])
    x0, x1 = ax.get_xlim()
    y0, y1 = ax.get_ylim()
    size = 0.07 * min(x1 - x0, y1 - y0)
    centre = np.array([x1 - 0.08 * (x1 - x0), y1 - 0.1 * (y1 - y0)])
    tail, tip = centre - north * size / 2, centre + north * size / 2
    ax.annotate("", xy=tip, xytext=tail, zorder=9,
                arrowprops=dict(arrowstyle="-|>,head_width=0.4,head_length=0.8", color="k", lw=1.5))
    label = "N" if building.georef is not None else "N (plan)"
    ax.text(*(tip + north * size * 0.25), label, ha="center", va="center", fontsize=8,
            weight="bold", zorder=9)
    return north


def save_floor_images(building: Building, out_dir: str | Path, *, patterns: Any = None,
                      dpi: int = 150) -> list[Path]:
    """Write ``<out_dir>/<building>_floor<i>.png`` for every floor, labelled, with a scale
    bar and a north arrow; returns the paths.

    ``patterns`` as for :func:`draw_floor` (a SearchPatterns object covers all floors).
    """
    from ..figures import pyplot, save_figure
    plt = pyplot()

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for floor in building.floors:
        x0, y0, x1, y1 = _extent(building, floor.index)
        w, h = x1 - x0, y1 - y0
        fig, ax = plt.subplots(figsize=(min(16, 3 + 10 * w / max(w, h)), min(16, 3 + 10 * h / max(w, h))))
        draw_floor(ax, building, floor.index, labels=True, patterns=patterns)
        scale_bar(ax)
        north_arrow(ax, building)
        where = "" if building.georef is None else (
            f", origin {building.georef.lat:.6f}, {building.georef.lon:.6f}")
        ax.set_title(f"{building.name}: floor {floor.index} ({floor.name}), "
                     f"z = {floor.z:g} m{where}")
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        ax.grid(alpha=0.25, lw=0.5)
        fig.tight_layout()
        paths.append(save_figure(fig, out / f"{building.name}_floor{floor.index}.png", dpi=dpi,
                                 tight=False))
    return paths
