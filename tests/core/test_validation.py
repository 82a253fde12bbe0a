"""Pipeline validation: every problem reported with file:line:col and a useful message."""
from __future__ import annotations

import pytest

from firenav_framework import Params
from firenav_framework.capabilities import ParticleConstraint
from firenav_framework.pipeline import load_pipeline, load_pipeline_text
from firenav_framework.yaml_locations import ConfigError

from tests.core.toys import toy_registry

REG = toy_registry()

GOOD = """\
name: toy
sources:
  - id: src
    plugin: script
    steps: [[1, a, 1.0], [2, a, 1.0]]
estimators:
  - id: dr
    plugin: integrate
    input: src.odo
    gain: 1.0
sinks:
  - plugin: csv_tracks
    input: dr.pose
"""


def problems(text: str, **kw) -> list[str]:
    with pytest.raises(ConfigError) as info:
        load_pipeline_text(text, file="p.yaml", registry=REG, **kw)
    return [str(p) for p in info.value.problems]


def test_good_pipeline_validates_and_resolves_streams():
    spec = load_pipeline_text(GOOD, registry=REG)
    assert [c.id for c in spec.components] == ["src", "dr", "csv_tracks"]
    assert spec.by_id("dr").inputs == ["src.odo"]
    assert spec.by_id("dr").params.gain == 1.0


def test_out_of_range_parameter_points_at_its_line_and_column():
    text = GOOD.replace("gain: 1.0", "gain: -2")
    assert problems(text) == ["p.yaml:10:5: estimators[0].gain: must be greater than 0"]


def test_wrong_type_is_reported_in_plain_words():
    text = GOOD.replace("gain: 1.0", "gain: lots")
    (msg,) = problems(text)
    assert msg.startswith("p.yaml:10:5: estimators[0].gain: must be a valid number")


def test_unknown_plugin_suggests_the_closest_names():
    text = GOOD.replace("plugin: integrate", "plugin: integrat")
    (msg,) = problems(text)
    assert msg == ("p.yaml:8:5: estimators[0].plugin: unknown estimator plugin 'integrat'; "
                   "did you mean 'integrate'?")


def test_plugin_of_another_kind_is_named_as_such():
    text = GOOD.replace("plugin: integrate", "plugin: csv_tracks")
    (msg,) = problems(text)
    assert "'csv_tracks' is a sink plugin, not a estimator" in msg or \
        "'csv_tracks' is a sink plugin, not an estimator" in msg


def test_unknown_parameter_suggests_the_right_one():
    text = GOOD.replace("gain: 1.0", "gian: 1.0")
    (msg,) = problems(text)
    assert msg == "p.yaml:10:5: estimators[0].gian: unknown parameter; did you mean 'gain'?"


def test_stream_nobody_produces():
    text = GOOD.replace("input: src.odo", "input: src.odometry")
    (msg,) = problems(text)
    assert msg.startswith("p.yaml:9:5: estimators[0].input: stream 'src.odometry' is "
                          "produced by nobody; did you mean 'src.odo'")


def test_stream_of_the_wrong_type():
    text = GOOD.replace("input: src.odo", "input: src.truth")
    (msg,) = problems(text)
    assert "carries GroundTruth messages, but integrate reads Odometry" in msg


def test_two_components_with_one_id():
    text = GOOD + "  - id: csv_tracks\n    plugin: geojson_tracks\n    input: dr.pose\n"
    (msg,) = problems(text)
    assert msg == ("p.yaml:14:5: sinks[1].id: two components have the id 'csv_tracks' "
                   "(the other is at line 12); give each a unique id")


def test_constraint_on_an_estimator_that_cannot_use_it():
    class NeedsParticles(ParticleConstraint):
        """Needs particles."""
        name = "needs_particles"

        class Params(Params):
            pass

        def log_likelihood(self, step):
            return None

    reg = toy_registry()
    reg.add(NeedsParticles, package="toys")
    text = GOOD.replace("    gain: 1.0\n", "    gain: 1.0\n    constraints:\n"
                        "      - plugin: needs_particles\n")
    with pytest.raises(ConfigError) as info:
        load_pipeline_text(text, file="p.yaml", registry=reg)
    (p,) = info.value.problems
    assert (p.line, p.col) == (12, 9)
    assert p.message == ("constraint 'needs_particles' is a ParticleConstraint; 'dr' (integrate) "
                         "accepts no constraints")


def test_missing_input_and_missing_source():
    text = "estimators:\n  - plugin: integrate\n"
    msgs = problems(text)
    assert any("integrate needs an 'input' stream (Odometry)" in m for m in msgs)
    assert any("a pipeline needs at least one source" in m for m in msgs)


def test_malformed_yaml_reports_the_syntax_error_location():
    (msg,) = problems("sources:\n  - id: [unclosed\n")
    assert msg.startswith("p.yaml:3:1: YAML syntax error")


def test_unsafe_yaml_tags_are_refused():
    (msg,) = problems("sources: !!python/object/apply:os.system ['true']\n")
    assert msg == ("p.yaml:1:10: sources: unsupported YAML tag "
                   "'tag:yaml.org,2002:python/object/apply:os.system'; only plain YAML is read")


def test_duplicate_keys_are_an_error():
    (msg,) = problems("name: a\nname: b\nsources: []\n")
    assert msg == "p.yaml:2:1: name: key appears twice in the same mapping"


def test_unknown_top_level_section():
    text = GOOD + "sink:\n  - plugin: csv_tracks\n"
    (msg,) = problems(text)
    assert msg == "p.yaml:14:1: sink: unknown section; did you mean 'sinks'?"


def test_loops_between_components_are_refused():
    text = GOOD.replace("input: src.odo", "input: [src.odo, dr2.pose]") + \
        "estimators_extra: x\n"
    text = text.replace("estimators_extra: x\n", "")
    text = text.replace("sinks:", "  - id: dr2\n    plugin: integrate\n    input: dr.pose\nsinks:")
    msgs = problems(text)
    assert any("carries PoseEstimate" in m for m in msgs)  # type check fires first


def test_overrides_change_values_and_errors_point_at_the_command_line(tmp_path):
    path = tmp_path / "p.yaml"
    path.write_text(GOOD)
    spec = load_pipeline(path, ["estimators.dr.gain=3"], registry=REG)
    assert spec.by_id("dr").params.gain == 3.0
    spec = load_pipeline(path, ["estimators[0].gain=4"], registry=REG)
    assert spec.by_id("dr").params.gain == 4.0
    with pytest.raises(ConfigError) as info:
        load_pipeline(path, ["estimators.dr.gain=-1"], registry=REG)
    assert str(info.value) == "--set: estimators.dr.gain=-1: must be greater than 0"
    with pytest.raises(ConfigError) as info:
        load_pipeline(path, ["estimators.drr.gain=1"], registry=REG)
    assert "no item 'drr' in estimators; did you mean 'dr'?" in str(info.value)


def test_every_problem_is_reported_at_once():
    text = GOOD.replace("gain: 1.0", "gain: 0").replace("plugin: csv_tracks", "plugin: csv")
    assert len(problems(text)) == 2


def test_a_missing_scenario_is_reported_at_validation(tmp_path):
    (tmp_path / "mine.yaml").write_text("not: a scenario\n")
    text = "sources:\n  - {id: sim, plugin: simulator, scenario: nowhere}\n"
    msgs = problems(text, base_dir=tmp_path)
    assert len(msgs) == 1 and "scenario 'nowhere' not found: no file " in msgs[0]
    assert "bundled: " in msgs[0] and "demo" in msgs[0]
    # a path relative to the pipeline's folder is found (and checked) before anything runs
    msgs = problems(text.replace("nowhere", "mine.yaml"), base_dir=tmp_path)
    assert len(msgs) == 1 and "invalid scenario" in msgs[0]


def test_sink_wildcards_leave_out_other_sinks_streams():
    text = GOOD + ("  - {id: log1, plugin: diagnostics_log, input: '*.diagnostics'}\n"
                   "  - {id: log2, plugin: diagnostics_log, input: '*.diagnostics', "
                   "file: d2.jsonl}\n")
    spec = load_pipeline_text(text, registry=REG)
    assert spec.by_id("log1").inputs == ["dr.diagnostics", "src.diagnostics",
                                         "timeline.diagnostics"]
    assert spec.by_id("log2").inputs == spec.by_id("log1").inputs   # no loop between them
    # named explicitly, a sink's stream can still be read
    spec = load_pipeline_text(text.replace("input: '*.diagnostics', file",
                                           "input: [log1.diagnostics], file"), registry=REG)
    assert spec.by_id("log2").inputs == ["log1.diagnostics"]
