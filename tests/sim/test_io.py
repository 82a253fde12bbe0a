"""Scenario errors point at the YAML line; outputs round-trip; the source plays a run."""
from __future__ import annotations

import json

import numpy as np
import pytest

from firenav_framework.cli import main
from firenav_framework.pipeline import load_pipeline_text
from firenav_framework.runner import run_pipeline
from firenav_framework.simulator import simulate
from firenav_framework.simulator.output import write_simulation
from firenav_framework.simulator.scenario import load_scenario, load_scenario_text
from firenav_framework.sources.readers import ReadOptions, find_reader
from firenav_framework.sources.readers import ReaderError
from firenav_framework.yaml_locations import ConfigError

GOOD = """\
name: t
building: corridor
agents:
  - id: a
    start: {position: [5.12, 8.4], floor: 0, time_s: 2}
    plan:
      - walk: {via: [[12.0, 8.4]]}
"""


def _problems(text: str) -> list[str]:
    with pytest.raises(ConfigError) as exc:
        load_scenario_text(text, file="s.yaml")
    return [str(p) for p in exc.value.problems]


@pytest.mark.parametrize("change,line,needle", [
    ("      - walk: {via: [[12.0, 8.4]]}", 7, None),                      # valid
    ("      - jog: {to: [1, 2]}", 7, "unknown plan step 'jog'"),
    ("      - walk: {via: [[12.0, 8.4]], gait: skip}", 7, "unknown gait 'skip'"),
    ("      - walk: {via: [[12.0, 8.4]], speed: 3}", 7, "unknown parameter"),
    ("      - wait: -3", 7, "takes a duration in seconds"),
    ("      - walk: {}", 7, "give either 'to'"),
])
def test_plan_step_problems_name_the_line(change, line, needle):
    text = GOOD.replace("      - walk: {via: [[12.0, 8.4]]}", change)
    if needle is None:
        assert load_scenario_text(text).steps["a"]
        return
    probs = _problems(text)
    assert any(f"s.yaml:{line}:" in p and needle in p for p in probs), probs


def test_other_scenario_problems_are_located():
    probs = _problems(GOOD.replace("building: corridor", "building: nowhere.geojson"))
    assert any("s.yaml:2:" in p and "neither a bundled plan" in p for p in probs), probs
    text = GOOD + "    sensors: {imu: {grade: mems9000}}\n"
    assert any("s.yaml:8:" in p and "unknown IMU grade" in p for p in _problems(text))
    text = GOOD + "  - id: b\n    follow: {agent: zz}\n"
    assert any("s.yaml:9:" in p and "no other agent 'zz'" in p for p in _problems(text))
    text = GOOD + "  - id: a\n    plan: []\n"
    assert any("used twice" in p for p in _problems(text))


def test_plans_that_cannot_be_walked_are_located():
    through_wall = GOOD.replace("[[12.0, 8.4]]", "[[12.0, 3.0]]")
    with pytest.raises(ConfigError) as exc:
        simulate(load_scenario_text(through_wall, file="s.yaml"), 0)
    assert "s.yaml:7:" in str(exc.value) and "crosses a wall" in str(exc.value)
    no_door = GOOD.replace("{via: [[12.0, 8.4]]}", "{to: {door: d_nowhere}}")
    with pytest.raises(ConfigError, match="s.yaml:7:.*no door or opening 'd_nowhere'"):
        simulate(load_scenario_text(no_door, file="s.yaml"), 0)
    outside = GOOD.replace("{via: [[12.0, 8.4]]}", "{to: [80.0, 8.4]}")
    with pytest.raises(ConfigError, match="outside the building"):
        simulate(load_scenario_text(outside, file="s.yaml"), 0)
    with pytest.raises(ConfigError, match="no such scenario file.*bundled: .*demo"):
        load_scenario("no_such_scenario")


def test_outputs_round_trip_through_the_recording_reader(tmp_path):
    r = simulate("demo", 4, duration_s=60)
    files = write_simulation(r, tmp_path, foot_truth=True)
    names = {f.name for f in files}
    assert {"imu_ff1.csv", "imu_ff2.csv", "streams.jsonl", "truth.csv", "truth.json",
            "foot_ff1.csv", "scenario.yaml"} <= names
    reader = find_reader(tmp_path / "streams.jsonl")(tmp_path / "streams.jsonl",
                                                    ReadOptions(block_s=0.5))
    got: dict[str, list] = {}
    for port, msg in reader:
        got.setdefault(port, []).append(msg)
    for port in ("uwb", "rssi", "rfid", "tags", "drops"):
        want = r.messages.get(port, [])
        assert len(got.get(port, [])) == len(want), port
        for a, b in zip(got.get(port, []), want):
            assert type(a) is type(b) and a.t == b.t and a.agent == b.agent
    assert [m.range_m for m in got["uwb"][:20]] == [m.range_m for m in r.messages["uwb"][:20]]
    # IMU samples are written bit-exact
    imu = [b for b in got["imu"] if b.agent == "ff1"]
    acc = np.concatenate([b.accel for b in imu])
    assert np.array_equal(acc, r.imu["ff1"].accel)
    assert len(got["truth"]) == sum(len(tr.t) for tr in r.truth.values())
    static = json.loads((tmp_path / "truth.json").read_text())
    assert set(static["tags"]) == set(r.tags)
    assert static["agents"]["ff1"]["imu"]["grade"] == "xsens_mti3"


def test_reader_counts_bad_lines_and_refuses_missing_files(tmp_path):
    r = simulate("orca_test1", 0, duration_s=20)
    write_simulation(r, tmp_path)
    path = tmp_path / "streams.jsonl"
    lines = path.read_text().splitlines()
    lines.insert(2, "{not json")
    lines.insert(3, json.dumps({"type": "teleport", "t": 1.0}))
    lines.insert(4, json.dumps({"type": "range", "t": 1.0, "b": "x"}))
    path.write_text("\n".join(lines) + "\n")
    counts: dict[str, int] = {}
    opts = ReadOptions(count=lambda what, n=1: counts.__setitem__(what, counts.get(what, 0) + n))
    msgs = list(find_reader(path)(path, opts))
    assert counts == {"bad_rows": 2, "unknown_records": 1}
    assert sum(1 for p, _ in msgs if p == "uwb") == len(r.messages["uwb"])
    (tmp_path / "imu_ff1.csv").unlink()
    with pytest.raises(ReaderError, match="imu_ff1.csv, which is missing"):
        find_reader(path)(path, ReadOptions())


def test_simulator_source_runs_in_a_pipeline_and_declares_only_its_ports(tmp_path):
    text = """
name: simrun
sources:
  - {id: sim, plugin: simulator, scenario: orca_test1, seed: 2, duration: 30}
sinks:
  - {plugin: diagnostics_log, input: sim.diagnostics}
"""
    spec = load_pipeline_text(text, base_dir=tmp_path)
    ports = set(spec.by_id("sim").outputs)
    assert ports == {"imu", "uwb", "truth", "diagnostics"}
    result = run_pipeline(spec, output_dir=tmp_path)
    assert set(result.truth) == {"ff1"}
    assert result.t_last == pytest.approx(30.0, abs=0.2)
    assert result.components["sim"].building().name == "corridor"
    assert result.stats.as_dict()["messages"]["sim.imu"] == 300


def test_bad_scenario_in_a_pipeline_is_reported_at_its_parameter(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text(GOOD.replace("walk:", "jog:"))
    text = f"""
sources:
  - {{id: sim, plugin: simulator, scenario: {bad}}}
"""
    with pytest.raises(ConfigError) as exc:
        load_pipeline_text(text, file="p.yaml", base_dir=tmp_path)
    msg = str(exc.value)
    assert "p.yaml:3:" in msg and "bad.yaml:7:" in msg and "unknown plan step 'jog'" in msg
    with pytest.raises(ConfigError, match="scenario 'gone.yaml' not found: no file "):
        load_pipeline_text("sources:\n  - {id: sim, plugin: simulator, scenario: gone.yaml}\n",
                           file="p.yaml", base_dir=tmp_path)


def test_cli_simulate_writes_a_folder(tmp_path, capsys):
    assert main(["simulate", "orca_test2", "--seed", "3", "--duration", "15",
                 "--out", str(tmp_path / "o")]) == 0
    out = capsys.readouterr().out
    assert "orca_test2 seed 3" in out and (tmp_path / "o" / "streams.jsonl").is_file()
    assert main(["simulate", "--list"]) == 0
    assert "orca_test3" in capsys.readouterr().out
    assert main(["simulate", "nope"]) == 2
    assert main(["simulate", "demo", "--seed", "-1"]) == 2
