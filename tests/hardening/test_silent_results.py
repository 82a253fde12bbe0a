"""Values that used to give a silent bad result with exit 0 are refused at validation."""
from __future__ import annotations

import pytest

from firenav_framework.cli import main

PIPELINE = """
sources: [{id: sim, plugin: simulator, scenario: demo, duration: 3}]
sensors: [{id: imu, plugin: foot_imu, input: sim.imu}]
estimators:
  - {id: ins, plugin: zupt_ins, input: imu.imu}
  - {id: pf, plugin: particle_filter, input: ins.odometry, EXTRA}
"""


@pytest.mark.parametrize("extra, where, message", [
    ("start: {mode: pose, position: [.nan, 1.0, 0.0]}", "estimators[1].start.position[0]",
     "finite number"),                                 # was an all-NaN track marked trusted
    ("start: {mode: pose, position: [1.0, 1.0, .nan]}", "estimators[1].start.position[2]",
     "finite number"),                                 # a NaN altitude: was no poses, no word
    ("start: {mode: pose, position: [1, 1, 0], heading: .nan}", "estimators[1].start.heading",
     "finite number"),
    ("start: {mode: pose, position: [1, 1, 0], agents: {ff1: {position: [.inf, 0, 0]}}}",
     "estimators[1].start.agents.ff1.position[0]", "finite number"),
    ("particles: 2000000000", "estimators[1].particles", "less than or equal to 100000"),
])
def test_non_finite_starts_and_huge_sizes_are_refused_with_a_location(tmp_path, capsys, extra,
                                                                      where, message):
    path = tmp_path / "p.yaml"
    path.write_text(PIPELINE.replace("EXTRA", extra))
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err
    assert f"p.yaml:6:" in err and where in err and message in err, err


def test_a_nan_in_any_parameter_is_refused(tmp_path, capsys):
    # time_offset has no bounds, so nothing refused .nan before (every time became NaN)
    path = tmp_path / "p.yaml"
    (tmp_path / "r.csv").write_text("t,ax,ay,az,gx,gy,gz\n")
    path.write_text("sources: [{id: rec, plugin: recording, path: r.csv, time_offset: .nan}]\n"
                    "timeline: {duplicate_memory: 2000000000}\n")
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err
    assert "p.yaml:1:" in err and "sources[0].time_offset: must be a number, not NaN" in err
    assert "p.yaml:2:" in err and "timeline.duplicate_memory: must be less than or equal" in err


def test_the_breadcrumb_graph_window_cannot_be_set_beyond_memory(tmp_path, capsys):
    """A window of a billion states was accepted and grew the graph without bound."""
    path = tmp_path / "p.yaml"
    path.write_text(
        "sources: [{id: sim, plugin: simulator, scenario: demo, duration: 3}]\n"
        "sensors: [{id: imu, plugin: foot_imu, input: sim.imu}]\n"
        "estimators:\n"
        "  - {id: ins, plugin: zupt_ins, input: imu.imu}\n"
        "  - {id: gen, plugin: breadcrumb_gen, input: ins.odometry,\n"
        "     graph: {window_max: 1000000000, max_active_dims: 1000000000}}\n")
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err
    assert "estimators[1].graph.window_max: " in err and "less than or equal to 10000" in err
    assert "estimators[1].graph.max_active_dims: " in err
