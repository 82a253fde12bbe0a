"""A PNG of the tracks over the floor plan, with ground truth and uncertainty ellipses."""
from __future__ import annotations

import numpy as np

from ..components import param, Params
from ..messages import GroundTruth, PoseEstimate
from ..tracks import TrackStore
from .base import FileSink


class TrackPlot(FileSink):
    """Plot estimated tracks (and ground truth when present) over the building to a PNG."""

    name = "track_plot"
    inputs = (PoseEstimate, GroundTruth)

    class Params(Params):
        file: str = param("tracks.png", description="file name under the output folder")
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
        from matplotlib.patches import Ellipse

        tracks, truth = self._store.tracks(), self._store.truth()
        if not tracks and not truth:
            return
        fig, ax = plt.subplots(figsize=(9, 7))
        building = None
        try:
            building = self.ctx.building
        except RuntimeError:
            pass
        if building is not None:
            from ..building.plot import draw_floor
            draw_floor(ax, building, 0)
        colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
        for i, (agent, tr) in enumerate(truth.items()):
            ax.plot(tr.position[:, 0], tr.position[:, 1], "--", color="k", lw=1,
                    alpha=0.6, label=f"truth {agent}" if i == 0 else None)
        k = 0
        for stream, agents in tracks.items():
            for agent, tr in agents.items():
                c = colors[k % len(colors)]
                k += 1
                ax.plot(tr.position[:, 0], tr.position[:, 1], "-", color=c, lw=1.3,
                        label=f"{stream} {agent}")
                next_t = -np.inf
                for t, p, cov in zip(tr.t, tr.position, tr.cov):
                    if t < next_t or not np.all(np.isfinite(cov[:2, :2])):
                        continue
                    next_t = t + self.params.ellipse_every
                    w, v = np.linalg.eigh(cov[:2, :2])
                    w = np.sqrt(np.maximum(w, 0)) * 2 * 2.0  # 2-sigma, full axes
                    ang = np.degrees(np.arctan2(v[1, 1], v[0, 1]))
                    ax.add_patch(Ellipse(p[:2], w[1], w[0], angle=ang, fill=False,
                                         color=c, lw=0.7, alpha=0.7))
        ax.set_aspect("equal")
        ax.set_xlabel("east [m]")
        ax.set_ylabel("north [m]")
        ax.grid(alpha=0.3)
        ax.legend(loc="best", fontsize=7)
        fig.tight_layout()
        fig.savefig(self.out_path(self.params.file), dpi=self.params.dpi)
        plt.close(fig)
PLUGINS = [TrackPlot]
