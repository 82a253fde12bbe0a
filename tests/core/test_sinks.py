"""Built-in sinks: track plot floors, diagnostics log."""
from __future__ import annotations

import json
import time
from datetime import datetime

import numpy as np

from firenav_framework.building import bundled_plan, load_building
from firenav_framework.messages import Diagnostic, PoseEstimate
from firenav_framework.sinks.diagnostics_log import DiagnosticsLogSink
from firenav_framework.sinks.track_plot import TrackPlotSink, floors_of
from firenav_framework.testing import check_plugin, run_component
from firenav_framework.tracks import TrackStore


def pose(t, z, floor=None):
    return PoseEstimate(t=t, agent="ff1", position=np.array([2.0 + t, 3.0, z]), heading=0.0,
                        cov=np.eye(4) * 0.2, floor=floor)


def test_floors_come_from_the_estimate_or_else_from_height():
    building = load_building(bundled_plan("three_storey"))
    store = TrackStore()
    for t, z, floor in [(0, 0.0, None), (1, 3.4, None), (2, 7.1, None), (3, 0.0, 2)]:
        store("pf.pose", pose(t, z, floor))
    tr = store.tracks()["pf.pose"]["ff1"]
    assert floors_of(tr, building).tolist() == [0, 1, 2, 2]
    assert floors_of(tr, None).tolist() == [0, 0, 0, 2]


def test_track_plot_writes_a_png_per_run(tmp_path):
    building = load_building(bundled_plan("three_storey"))
    msgs = [("pf.pose", pose(t, 0.0 if t < 5 else 3.5)) for t in range(10)]
    check_plugin(TrackPlotSink, {"ellipse_every": 2.0}, sample_input=msgs, building=building,
                 output_dir=tmp_path)
    png = (tmp_path / "tracks.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n"


def test_diagnostics_log_writes_one_json_object_per_line(tmp_path):
    d = Diagnostic(t=1.5, agent="ff2", component="pf", level="warning", code="map_error",
                   text="estimate not trustworthy")
    run_component(DiagnosticsLogSink, {}, [("pf.diagnostics", d)], output_dir=tmp_path)
    (line,) = (tmp_path / "diagnostics.jsonl").read_text().splitlines()
    entry = json.loads(line)
    wall = datetime.fromisoformat(entry.pop("wall"))  # when the line was written
    assert abs(wall.timestamp() - time.time()) < 600
    assert entry == {"t": 1.5, "when": "t=1.5 s", "stream": "pf.diagnostics",
                     "component": "pf", "agent": "ff2", "level": "warning",
                     "code": "map_error", "active": True, "text": "estimate not trustworthy"}


def test_track_plot_draws_the_same_png_in_a_renderer_process(tmp_path):
    from firenav_framework.sinks.track_plot import background_rendering

    building = load_building(bundled_plan("three_storey"))
    msgs = [("pf.pose", pose(t, 0.0 if t < 5 else 3.5)) for t in range(10)]
    (tmp_path / "a").mkdir(), (tmp_path / "b").mkdir()
    run_component(TrackPlotSink, {}, msgs, building=building, output_dir=tmp_path / "a")
    with background_rendering():
        run_component(TrackPlotSink, {}, msgs, building=building, output_dir=tmp_path / "b")
    assert (tmp_path / "b" / "tracks.png").read_bytes() == (tmp_path / "a" / "tracks.png").read_bytes()


def test_position_ellipse_is_drawn_only_where_position_and_covariance_are_finite():
    """A pose with a NaN position (bad input the conformance suite feeds) gets no ellipse,
    so matplotlib never transforms a NaN centre; a finite one gets its 2-sigma ellipse
    whose full axes are 4 sigma (analytic: sigma 1 m and 0.5 m -> 4 m and 2 m)."""
    from firenav_framework.figures import add_position_ellipse, pyplot
    plt = pyplot()
    fig, ax = plt.subplots()
    cov = np.diag([1.0, 0.25, 0.0])
    assert not add_position_ellipse(ax, np.array([np.nan, 0.0]), cov, "k", lw=1)
    assert not add_position_ellipse(ax, np.zeros(2), np.full((3, 3), np.nan), "k", lw=1)
    assert len(ax.patches) == 0
    assert add_position_ellipse(ax, np.array([2.0, 3.0]), cov, "k", lw=1)
    (e,) = ax.patches
    assert sorted([e.width, e.height]) == [2.0, 4.0]
    assert tuple(e.center) == (2.0, 3.0)
    plt.close(fig)
