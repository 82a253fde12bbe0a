"""The firenav command line: validate, run, plugins list/show, exit codes."""
from __future__ import annotations

import json

import pytest

import firenav_framework.cli.plugins as cli_plugins
import firenav_framework.cli.run as cli_run
import firenav_framework.pipeline as pipeline_mod
from firenav_framework.cli import main

from tests.core.toys import toy_registry

PIPE = """\
name: cli_toy
sources:
  - id: src
    plugin: script
    steps: [[1, ff1, 1.0], [2, ff1, 1.0], [3, ff1, 2.0]]
estimators:
  - id: dr
    plugin: integrate
    input: src.odo
sinks:
  - {plugin: csv_tracks, input: dr.pose}
  - {plugin: geojson_tracks, input: dr.pose}
"""


@pytest.fixture(autouse=True)
def toys(monkeypatch):
    reg = toy_registry()
    for mod in (cli_plugins, cli_run, pipeline_mod):
        monkeypatch.setattr(mod, "default_registry", lambda: reg)


@pytest.fixture
def pipe(tmp_path):
    path = tmp_path / "p.yaml"
    path.write_text(PIPE)
    return path


def test_validate_ok_lists_the_wiring(pipe, capsys):
    assert main(["validate", str(pipe)]) == 0
    out = capsys.readouterr().out
    assert "ok (4 components)" in out
    assert "estimator  dr" in out and "in: src.odo" in out


def test_validate_reports_located_errors_with_exit_code_2(pipe, capsys):
    pipe.write_text(PIPE.replace("plugin: integrate", "plugin: integrat"))
    assert main(["validate", str(pipe)]) == 2
    err = capsys.readouterr().err
    assert f"error: {pipe}:8:5: estimators[0].plugin: unknown estimator plugin 'integrat'; " \
           "did you mean 'integrate'?" in err


def test_validate_missing_file(tmp_path, capsys):
    assert main(["validate", str(tmp_path / "nope.yaml")]) == 2
    assert "cannot read" in capsys.readouterr().err


def test_run_writes_tracks_summary_and_honours_set(pipe, tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["run", str(pipe), "--output", str(out), "--quiet",
                 "--set", "estimators.dr.gain=2"]) == 0
    text = capsys.readouterr().out
    assert "Run summary: cli_toy" in text and "dr.pose  ff1: 3 poses, 6.0 m" in text
    rows = (out / "dr_pose.csv").read_text().splitlines()
    assert rows[-1].startswith("3.0,ff1,8.0,")           # (1 + 1 + 2) * gain 2
    summary = json.loads((out / "summary.json").read_text())
    assert summary["messages"]["src.odo"] == 3
    geo = json.loads((out / "tracks.geojson").read_text())
    assert geo["features"][0]["geometry"]["coordinates"][-1][:2] == [8.0, 0.0]


def test_run_input_sets_the_file_source_parameter(pipe, tmp_path, capsys):
    data = tmp_path / "rec.bin"
    data.write_bytes(b"x")
    assert main(["run", str(pipe), "--input", str(data), "--output", str(tmp_path / "o"),
                 "--quiet"]) == 0
    assert main(["run", str(pipe), "--input", str(tmp_path / "missing"), "--quiet"]) == 2
    assert "no such file" in capsys.readouterr().err


def test_plugins_list_and_show(capsys):
    assert main(["plugins", "list"]) == 0
    out = capsys.readouterr().out
    assert "estimators:" in out and "integrate" in out and "toys" in out
    assert main(["plugins", "show", "integrate"]) == 0
    out = capsys.readouterr().out
    assert "integrate (estimator) from toys" in out
    line = next(ln for ln in out.splitlines() if ln.startswith("gain"))
    assert line.split()[:3] == ["gain", "float", "1.0"] and line.endswith("[> 0]")
    fail_t = next(ln for ln in out.splitlines() if ln.startswith("fail_t"))
    assert " s " in fail_t  # the unit column


def test_plugins_show_unknown_suggests(capsys):
    assert main(["plugins", "show", "integrat"]) == 2
    assert "did you mean 'integrate'" in capsys.readouterr().err
