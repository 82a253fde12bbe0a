"""Output stays under --output: validate refuses names that leave it, located; and the
exit codes are the documented ones."""
from __future__ import annotations

import re

import pytest

from firenav_framework.cli import EXIT_CODES, build_parser, main
from firenav_framework.contract import OutputName, OutputPathError
from firenav_framework.contract.sink import output_name_problem

from tests.conftest import REPO

BASE = """name: NAME
sources: [{id: sim, plugin: simulator, scenario: demo, duration: 3}]
sinks:
  - {plugin: SINK, input: "*.diagnostics", file: FILE}
"""


def validate(tmp_path, capsys, name="ok", sink="diagnostics_log", file="d.jsonl"):
    path = tmp_path / "p.yaml"
    path.write_text(BASE.replace("NAME", name).replace("SINK", sink).replace("FILE", file))
    code = main(["validate", str(path)])
    return code, capsys.readouterr().err


@pytest.mark.parametrize("file", ["../../x.jsonl", "/tmp/x.jsonl", "~/x.jsonl", "a/../../x",
                                  "''"])
def test_validate_refuses_a_sink_file_that_leaves_the_output_folder(tmp_path, capsys, file):
    code, err = validate(tmp_path, capsys, file=file)
    assert code == 2
    assert re.search(r"p\.yaml:4:\d+: sinks\[0\]\.file: .*files are written inside the "
                     r"output folder|is empty", err), err


def test_every_file_sink_declares_its_names_as_output_names(tmp_path, capsys):
    for sink in ("csv_tracks", "geojson_tracks", "track_plot", "mcap_recorder"):
        code, err = validate(tmp_path, capsys, sink=sink, file="../escape")
        assert code == 2 and "sinks[0].file" in err, (sink, err)
    assert validate(tmp_path, capsys, file="sub/dir/d.jsonl")[0] == 0  # inside is fine


@pytest.mark.parametrize("name", ["../../x", "/etc", "a/b", ".."])
def test_validate_refuses_a_pipeline_name_that_is_a_path(tmp_path, capsys, name):
    code, err = validate(tmp_path, capsys, name=name)
    assert code == 2 and "p.yaml:1:" in err and "must be a plain name" in err, err


def test_a_live_source_records_inside_the_output_folder_only(tmp_path, capsys):
    path = tmp_path / "p.yaml"
    path.write_text("sources: [{id: can, plugin: can_bus, interface: virtual, channel: x, "
                    "record_dir: ../raw}]\n")
    assert main(["validate", str(path)]) == 2
    assert "sources[0].record_dir" in capsys.readouterr().err


def test_output_name_rule_is_one_rule_for_validation_and_run_time(tmp_path):
    from firenav_framework.sinks.diagnostics_log import DiagnosticsLogSink
    from firenav_framework.testing import make_component
    assert output_name_problem("a/b.csv") is None
    assert output_name_problem("../a") and output_name_problem("/a")
    sink, _, _ = make_component(DiagnosticsLogSink, {}, output_dir=tmp_path)
    with pytest.raises(OutputPathError):
        sink.out_path("../../etc/x")
    (tmp_path / "link").symlink_to("/tmp")             # a symlink out is refused at run time
    with pytest.raises(OutputPathError):
        sink.out_path("link/x")
    assert OutputName is not None


def test_readme_and_help_state_the_same_exit_codes():
    readme = (REPO / "README.md").read_text()
    help_text = build_parser().format_help()
    assert EXIT_CODES in help_text and EXIT_CODES in readme
    assert re.findall(r"^  (\d+) ", EXIT_CODES, re.M) == ["0", "1", "2", "130"]


def test_a_run_with_a_plugin_fault_exits_1_and_a_clean_one_0(tmp_path, capsys, monkeypatch):
    from tests.core.toys import toy_registry
    reg = toy_registry()
    monkeypatch.setattr("firenav_framework.pipeline.default_registry", lambda: reg)
    steps = [[float(t), a, 1.0] for t in range(1, 6) for a in ("ff1", "ff2")]
    text = (f"sources: [{{id: src, plugin: script, steps: {steps}}}]\n"
            "estimators: [{id: dr, plugin: integrate, input: src.odo, fail_agent: FAIL, "
            "fail_t: 3.0}]\n")
    for fail, code in (("nobody", 0), ("ff1", 1)):
        path = tmp_path / f"{fail}.yaml"
        path.write_text(text.replace("FAIL", fail))
        assert main(["run", str(path), "--quiet", "--output", str(tmp_path / fail)]) == code
        out = capsys.readouterr()
        assert ("error: 1 plugin fault(s)" in out.err) == (code == 1), out.err
        assert "Plugin faults:" in out.out                # the summary is printed either way
