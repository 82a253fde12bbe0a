"""Running pipelines: fault isolation, determinism, live sources, ticks, summaries."""
from __future__ import annotations

import json

import numpy as np
import pytest

from firenav_framework.pipeline import load_pipeline_text
from firenav_framework.runner import run_pipeline
from firenav_framework.summary import format_summary, summary_dict
from firenav_framework.tracks import read_csv

from tests.core.toys import toy_registry

REG = toy_registry()
STEPS = [[float(t), a, 1.0] for t in range(1, 11) for a in ("ff1", "ff2")]


def pipeline(extra_est: str = "", source: str = "script", sinks: str = "") -> str:
    return f"""
name: t
sources:
  - {{id: src, plugin: {source}, steps: {json.dumps(STEPS)}}}
estimators:
  - {{id: dr, plugin: integrate, input: src.odo{extra_est}}}
sinks:
  - {{id: all, plugin: collect, input: "*"}}
  - {{plugin: csv_tracks, input: dr.pose}}
{sinks}"""


def run(text: str, tmp_path, **kw):
    spec = load_pipeline_text(text, registry=REG, base_dir=tmp_path)
    return run_pipeline(spec, output_dir=tmp_path, **kw)


def test_tracks_and_summary(tmp_path):
    res = run(pipeline(), tmp_path)
    tracks = res.tracks["dr.pose"]
    assert set(tracks) == {"ff1", "ff2"}
    np.testing.assert_allclose(tracks["ff1"].position[:, 0], np.arange(1, 11))
    assert tracks["ff1"].length_m == pytest.approx(9.0)
    d = summary_dict(res)
    assert d["messages"]["src.odo"] == 20 and d["messages"]["dr.pose"] == 20
    text = format_summary(res)
    assert "dr.pose  ff1: 10 poses, 9.0 m" in text
    # truth x = t, estimate x = t as well: zero error
    assert d["track_error"]["dr.pose"]["ff1"]["max_m"] == pytest.approx(0.0)


def test_csv_has_the_documented_columns_and_reads_back(tmp_path):
    run(pipeline(), tmp_path)
    lines = (tmp_path / "dr_pose.csv").read_text().splitlines()
    assert lines[0] == ("t,agent,x,y,z,heading,var_x,cov_xy,var_y,var_z,var_heading,"
                        "floor,trusted,protection_radius")
    assert lines[1] == "1.0,ff1,1.0,0.0,0.0,0.0,0.1,0.0,0.1,0.1,0.1,,1,inf"
    back = read_csv(tmp_path / "dr_pose.csv")
    np.testing.assert_allclose(back["ff2"].position[:, 0], np.arange(1, 11))


def test_same_input_gives_byte_identical_output(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir(), b.mkdir()
    run(pipeline(sinks="  - {plugin: geojson_tracks, input: dr.pose}"), a)
    run(pipeline(sinks="  - {plugin: geojson_tracks, input: dr.pose}"), b)
    for name in ("dr_pose.csv", "tracks.geojson"):
        assert (a / name).read_bytes() == (b / name).read_bytes()


def test_a_plugin_fault_disables_only_that_agent(tmp_path):
    res = run(pipeline(", fail_agent: ff2, fail_t: 4.0"), tmp_path)
    assert len(res.tracks["dr.pose"]["ff1"]) == 10       # the other firefighter is untouched
    assert len(res.tracks["dr.pose"]["ff2"]) == 3        # stopped at the failing step
    (fault,) = res.faults
    assert (fault.component, fault.agent, fault.t) == ("dr", "ff2", 4.0)
    assert "ValueError: scripted failure" in fault.error
    assert res.stats.counts["dr"]["skipped_after_fault"] == 6
    diags = [m for m in res.diagnostics if m.code == "plugin_fault"]
    assert len(diags) == 1 and diags[0].component == "dr" and diags[0].agent == "ff2"


def test_restart_policy_resets_the_agent_and_carries_on(tmp_path):
    res = run(pipeline(", fail_agent: ff2, fail_t: 4.0, on_error: restart"), tmp_path)
    ff2 = res.tracks["dr.pose"]["ff2"]
    assert len(ff2) == 9                                  # only the failing step is lost
    np.testing.assert_allclose(ff2.position[3:, 0], np.arange(1, 7))  # restarted from zero
    assert res.components["dr"].resets == ["ff2"]


def test_disable_policy_stops_the_whole_component(tmp_path):
    res = run(pipeline(", fail_agent: ff2, fail_t: 4.0, on_error: disable"), tmp_path)
    assert len(res.tracks["dr.pose"]["ff1"]) == 4 and len(res.tracks["dr.pose"]["ff2"]) == 3


def test_raise_policy_stops_the_run(tmp_path):
    with pytest.raises(ValueError, match="scripted failure"):
        run(pipeline(", fail_agent: ff2, fail_t: 4.0, on_error: raise"), tmp_path)


def test_live_source_runs_in_a_thread_and_gives_the_same_tracks(tmp_path):
    offline = run(pipeline(), tmp_path / "off")
    live = run(pipeline(source="live_script"), tmp_path / "live")
    for agent in ("ff1", "ff2"):
        np.testing.assert_array_equal(live.tracks["dr.pose"][agent].position,
                                      offline.tracks["dr.pose"][agent].position)


def test_realtime_pacing_keeps_order_and_content(tmp_path):
    steps = [[0.01 * i, "ff1", 1.0] for i in range(1, 6)]
    text = pipeline().replace(json.dumps(STEPS), json.dumps(steps))
    res = run(text, tmp_path, realtime=True, speed=10.0)
    np.testing.assert_allclose(res.tracks["dr.pose"]["ff1"].t, [0.01, 0.02, 0.03, 0.04, 0.05])


def test_components_get_ticks_at_their_period(tmp_path):
    res = run(pipeline(sinks="  - {id: tk, plugin: tick_counter, period: 2.5, "
                              "input: dr.diagnostics}"), tmp_path)
    assert res.components["tk"].ticks == [2.5, 5.0, 7.5, 10.0]


def test_collect_sink_sees_everything_in_time_order(tmp_path):
    res = run(pipeline(), tmp_path)
    got = res.components["all"].got
    times = [m.t for s, m in got if s == "src.odo"]
    assert times == sorted(times) and len(times) == 20
    # depth first: dr (subscribed first) handles the step and its pose reaches this sink
    # before the sink's own copy of the step does
    assert [s for s, _ in got[:3]] == ["dr.pose", "src.odo", "src.truth"]


def test_a_failing_source_is_a_contained_fault_and_the_others_keep_running(tmp_path):
    text = pipeline().replace(
        "sources:\n", "sources:\n  - {id: flaky, plugin: flaky_script, fail_after: 2, "
        "steps: [[1, ff3, 1.0], [2, ff3, 1.0], [3, ff3, 1.0]]}\n").replace(
        "input: src.odo", "input: [src.odo, flaky.odo]")
    res = run(text, tmp_path)
    assert len(res.tracks["dr.pose"]["ff1"]) == 10
    assert len(res.tracks["dr.pose"]["ff3"]) == 1        # one step arrived before the crash
    (fault,) = res.faults
    assert fault.component == "flaky" and "OSError: device vanished" in fault.error


def test_progress_lines_show_the_fraction_done(tmp_path):
    import io
    buf = io.StringIO()
    text = pipeline().replace("plugin: script", "plugin: flaky_script, fail_after: 1000")
    spec = load_pipeline_text(text, registry=REG, base_dir=tmp_path)
    run_pipeline(spec, output_dir=tmp_path, progress=buf, progress_every=0.0)
    lines = buf.getvalue().splitlines()
    assert lines[0].startswith("[firenav] t=1.0 s of 9 s (0%)")
    assert lines[-1].startswith("[firenav] t=10.0 s of 9 s (100%)")


def test_truth_in_another_frame_is_not_compared_without_alignment(tmp_path):
    res = run(pipeline().replace("plugin: script,", "plugin: script, truth_frame: vicon,"),
              tmp_path)
    d = summary_dict(res)
    assert d["track_error"] == {} and d["truth_in_other_frames"] == ["vicon"]
    assert "Ground truth is in the vicon frame" in format_summary(res)


def test_poses_in_their_own_odometry_frame_are_not_compared_with_truth(tmp_path):
    res = run(pipeline(", frame: odometry"), tmp_path)
    d = summary_dict(res)
    assert d["track_error"] == {} and d["streams_not_in_building_frame"] == ["dr.pose"]
    assert "Not compared with ground truth (in their own odometry frame): dr.pose" \
        in format_summary(res)


def test_start_up_objects_are_out_of_full_collections_only_while_running(tmp_path,
                                                                          monkeypatch):
    """What start-up built is frozen for the run (a full garbage collection would walk it
    and stall the message in hand) and collectable again afterwards (a process runs many
    pipelines: an evaluation, a sweep, the tests)."""
    import gc

    from firenav_framework import runner

    seen = []
    offline = runner.Runner._run_offline

    def watched(self, *args):
        seen.append(gc.get_freeze_count())
        return offline(self, *args)

    monkeypatch.setattr(runner.Runner, "_run_offline", watched)
    assert gc.get_freeze_count() == 0
    res = run(pipeline(), tmp_path)
    assert len(res.tracks["dr.pose"]) == 2
    assert seen and seen[0] > 1000
    assert gc.get_freeze_count() == 0
