"""A PNG of the tracks over the floor plan, with ground truth and uncertainty ellipses."""
from __future__ import annotations

from typing import Any

import numpy as np

from ..contract import FileSink, NoBuilding, OutputName, Params, param
from ..messages import GroundTruth, PoseEstimate
from ..tracks import Track, TrackStore


def floors_of(track: Track, building: Any) -> np.ndarray:
    """Floor index of every point: the estimate's own floor, else from its height."""
    floors = track.floor.copy()
    unknown = floors < 0
    if unknown.any():
        floors[unknown] = (building.floor_of_z(track.position[unknown, 2])
                           if building is not None else 0)
    return floors


def _on_floor(xy: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Points off this floor become NaN, so the line breaks where the track leaves it."""
    out = xy.astype(float).copy()
    out[~mask] = np.nan
    return out


class TrackPlotSink(FileSink):
    """Plot estimated tracks (and ground truth when present) over the building to a PNG."""

    name = "track_plot"
    inputs = (PoseEstimate, GroundTruth)

    class Params(Params):
        file: OutputName = param("tracks.png", description="file name under the output folder")
        ellipse_every: float = param(10.0, unit="s", gt=0, description="draw a 2-sigma "
                                     "position ellipse this often along each track")
        dpi: int = param(110, ge=30, le=600, description="image resolution")

    def start(self) -> None:
        self._store = TrackStore()

    def handle(self, stream: str, msg: PoseEstimate | GroundTruth) -> None:
        self._store(stream, msg)

    def finish(self) -> None:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        tracks, truth = self._store.tracks(), self._store.truth()
        if not tracks and not truth:
            return
        try:
            building = self.ctx.building
        except NoBuilding:
            building = None
        all_tracks = [tr for agents in tracks.values() for tr in agents.values()]
        all_tracks += list(truth.values())
        visited = sorted({int(f) for tr in all_tracks for f in np.unique(floors_of(tr, building))})
        fig, axes = plt.subplots(1, len(visited), figsize=(8 * len(visited), 7), squeeze=False)
        colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
        for ax, floor in zip(axes[0], visited):
            if building is not None and 0 <= floor < len(building.floors):
                from ..building.plot import draw_floor
                draw_floor(ax, building, floor)
            for i, (agent, tr) in enumerate(truth.items()):
                xy = _on_floor(tr.position[:, :2], floors_of(tr, building) == floor)
                ax.plot(xy[:, 0], xy[:, 1], "--", color="k", lw=1, alpha=0.6,
                        label="ground truth" if i == 0 else None)
            k = 0
            for stream, agents in tracks.items():
                for agent, tr in agents.items():
                    c = colors[k % len(colors)]
                    k += 1
                    here = floors_of(tr, building) == floor
                    xy = _on_floor(tr.position[:, :2], here)
                    ax.plot(xy[:, 0], xy[:, 1], "-", color=c, lw=1.3, label=f"{stream} {agent}")
                    self._ellipses(ax, tr, here, c)
            ax.set_title(f"floor {floor}" if len(visited) > 1 else "")
            ax.set_aspect("equal")
            ax.set_xlabel("east [m]")
            ax.set_ylabel("north [m]")
            ax.grid(alpha=0.3)
            ax.legend(loc="best", fontsize=7)
        fig.tight_layout()
        fig.savefig(self.out_path(self.params.file), dpi=self.params.dpi)
        plt.close(fig)

    def _ellipses(self, ax: Any, tr: Track, here: np.ndarray, color: str) -> None:
        from matplotlib.patches import Ellipse
        next_t = -np.inf
        for t, p, cov, ok in zip(tr.t, tr.position, tr.cov, here):
            if not ok or t < next_t or not np.all(np.isfinite(cov[:2, :2])):
                continue
            next_t = t + self.params.ellipse_every
            w, v = np.linalg.eigh(cov[:2, :2])
            axes_len = 2 * 2.0 * np.sqrt(np.maximum(w, 0))  # full axes of the 2-sigma ellipse
            ang = np.degrees(np.arctan2(v[1, 1], v[0, 1]))
            ax.add_patch(Ellipse(p[:2], axes_len[1], axes_len[0], angle=ang, fill=False,
                                 color=color, lw=0.7, alpha=0.7))

