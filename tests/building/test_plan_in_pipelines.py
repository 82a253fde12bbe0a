"""Plans named by pipelines and scenarios: a plan that cannot be loaded is refused by
`firenav validate` with its location; a pipeline plan that differs from the scenario's
gives a warning when the run starts."""
from __future__ import annotations

import logging
import shutil

import pytest

from firenav_framework.building import bundled_plan
from firenav_framework.cli import main
from firenav_framework.pipeline import load_pipeline
from firenav_framework.runner import Runner

SCENARIO = """name: tiny
building: {plan}
agents:
  - id: ff1
    start: {{position: [2.0, 2.0], floor: 0}}
    sensors: {{imu: null}}
    plan:
      - wait: 2
"""

PIPELINE = """name: p
{building}sources:
  - {{id: sim, plugin: simulator, scenario: tiny.yaml}}
"""


@pytest.fixture
def folder(tmp_path):
    (tmp_path / "no_floors.geojson").write_text(
        '{"type": "FeatureCollection", "features": [{"type": "Feature", "properties": '
        '{"kind": "wall", "floor": 0}, "geometry": {"type": "LineString", "coordinates": '
        '[[0, 0], [1, 0]]}}]}')
    shutil.copy(bundled_plan("flat_125"), tmp_path / "flat.geojson")
    shutil.copy(bundled_plan("corridor"), tmp_path / "corridor.geojson")
    return tmp_path


def write(folder, scenario_plan, pipeline_plan=None):
    (folder / "tiny.yaml").write_text(SCENARIO.format(plan=scenario_plan))
    path = folder / "pipe.yaml"
    path.write_text(PIPELINE.format(building=f"building: {pipeline_plan}\n" if pipeline_plan else ""))
    return path


def test_validate_refuses_a_pipeline_plan_that_cannot_be_loaded(folder, capsys):
    pipe = write(folder, "flat.geojson", "no_floors.geojson")
    assert main(["validate", str(pipe)]) == 2
    err = capsys.readouterr().err
    assert f"{pipe}:2:" in err and "building: the building plan cannot be loaded" in err
    assert "no 'floor' features" in err
    assert main(["run", str(pipe), "--quiet", "--output", str(folder / "out")]) == 2


def test_validate_refuses_a_scenario_plan_that_cannot_be_loaded(folder, capsys):
    pipe = write(folder, "no_floors.geojson")
    assert main(["validate", str(pipe)]) == 2
    err = capsys.readouterr().err
    assert f"{folder / 'tiny.yaml'}:2:" in err and "no 'floor' features" in err


def test_validate_refuses_an_oversized_plan(folder, capsys):
    big = folder / "huge.geojson"
    with open(big, "wb") as fh:
        fh.truncate(65 * 2 ** 20)               # sparse: 65 MiB of zeros, nothing read
    assert main(["validate", str(write(folder, "flat.geojson", "huge.geojson"))]) == 2
    assert "plans are limited to 64 MiB" in capsys.readouterr().err


def test_a_pipeline_plan_unlike_the_scenario_plan_is_warned_about(folder, caplog):
    caplog.set_level(logging.WARNING, logger="firenav.runner")
    result = Runner(load_pipeline(write(folder, "flat.geojson", "corridor.geojson"))).run()
    (d,) = [d for d in result.diagnostics if d.code == "plan_mismatch"]
    assert d.level == "warning" and "corridor.geojson" in d.text and "flat.geojson" in d.text
    assert "plan_mismatch" not in caplog.text and "is not the plan source 'sim' brings" in caplog.text


@pytest.mark.parametrize("pipeline_plan", [None, "flat.geojson"])
def test_no_warning_when_the_plans_agree(folder, caplog, pipeline_plan):
    caplog.set_level(logging.WARNING, logger="firenav.runner")
    result = Runner(load_pipeline(write(folder, "flat.geojson", pipeline_plan))).run()
    assert not [d for d in result.diagnostics if d.code == "plan_mismatch"]
    assert "is not the plan" not in caplog.text
