"""A PNG of the tracks over the floor plan, with ground truth and uncertainty ellipses.

Off the pipeline's critical path in a command-line run: matplotlib takes longer to
import than a short recording takes to process, so within :func:`background_rendering`
(``firenav run`` uses it) :meth:`TrackPlotSink.start` starts a renderer process
(:func:`serve`) that imports it on a free core while the pipeline runs; at
:meth:`~TrackPlotSink.finish` the tracks go to it and the sink waits for the PNG (the file
exists when ``finish`` returns). Elsewhere (a long-lived process, where the import is
paid once) and where no process can be started, it draws in-process.
"""
from __future__ import annotations

import contextlib
import os
import pickle
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from ..contract import FileSink, NoBuilding, OutputName, Params, param
from ..figures import add_position_ellipse, pyplot, save_figure
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
        file: OutputName = param("tracks.png")
        """file name under the output folder"""
        ellipse_every: float = param(10.0, unit="s", gt=0)
        """draw a 2-sigma position ellipse this often along each track"""
        dpi: int = param(110, ge=30, le=600)
        """image resolution"""

    def start(self) -> None:
        self._store = TrackStore()
        self._renderer = _start_renderer()

    def handle(self, stream: str, msg: PoseEstimate | GroundTruth) -> None:
        if np.shape(msg.position) != (3,):   # not a point: nothing to draw (counted)
            self.ctx.count("unplottable_positions")
            return
        self._store(stream, msg)

    def finish(self) -> None:
        tracks, truth = self._store.tracks(), self._store.truth()
        renderer, self._renderer = getattr(self, "_renderer", None), None
        if not tracks and not truth:
            if renderer is not None:
                renderer.communicate(b"", timeout=RENDER_TIMEOUT_S)
            return
        try:
            building = self.ctx.building
        except NoBuilding:
            building = None
        job = {"tracks": tracks, "truth": truth, "building": building,
               "path": self.out_path(self.params.file),
               "ellipse_every": self.params.ellipse_every, "dpi": self.params.dpi}
        if renderer is None:
            render(**job)
            return
        _, err = renderer.communicate(pickle.dumps(job), timeout=RENDER_TIMEOUT_S)
        if renderer.returncode:
            raise RuntimeError(f"track plot failed: {err.decode(errors='replace').strip()}")


#: How long :meth:`TrackPlotSink.finish` waits for the renderer process [s].
RENDER_TIMEOUT_S = 120.0


_background = [False]


@contextlib.contextmanager
def background_rendering() -> Iterator[None]:
    """Track plots started meanwhile draw in a renderer process (the module docstring)."""
    before, _background[0] = _background[0], True
    try:
        yield
    finally:
        _background[0] = before


def _start_renderer() -> subprocess.Popen | None:
    """A renderer process, when rendering in the background and a core is free for it
    (load average below the cores less one; on a busy machine it would only compete)."""
    if not _background[0] or os.getloadavg()[0] > (os.cpu_count() or 1) - 1:
        return None
    try:
        return subprocess.Popen([sys.executable, "-c", "from firenav_framework.sinks."
                                 "track_plot import serve; serve()"],
                                stdin=subprocess.PIPE, stdout=subprocess.DEVNULL,
                                stderr=subprocess.PIPE)
    except OSError:
        return None


def serve() -> None:
    """The renderer process: import matplotlib, then draw the job read from stdin (a
    pickled :func:`render` keyword set; nothing: exit)."""
    pyplot()
    data = sys.stdin.buffer.read()
    if data:
        render(**pickle.loads(data))


def render(tracks: dict[str, dict[str, Track]], truth: dict[str, Track], building: Any,
           path: Path, ellipse_every: float, dpi: int) -> None:
    """Draw ``tracks`` (stream -> agent -> Track) and ``truth`` (agent -> Track) over
    ``building`` (or None) into the PNG ``path``, one panel per floor visited, with a
    2-sigma position ellipse every ``ellipse_every`` seconds along each track."""
    plt = pyplot()
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
                _ellipses(ax, tr, here, c, ellipse_every)
        ax.set_title(f"floor {floor}" if len(visited) > 1 else "")
        ax.set_aspect("equal")
        ax.set_xlabel("east [m]")
        ax.set_ylabel("north [m]")
        ax.grid(alpha=0.3)
        ax.legend(loc="best", fontsize=7)
    fig.tight_layout()
    save_figure(fig, path, dpi=dpi, tight=False)


def _ellipses(ax: Any, tr: Track, here: np.ndarray, color: str, every: float) -> None:
    next_t = -np.inf
    for t, p, cov, ok in zip(tr.t, tr.position, tr.cov, here):
        if ok and t >= next_t and add_position_ellipse(ax, p[:2], cov, color, lw=0.7):
            next_t = t + every
