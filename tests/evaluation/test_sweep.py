"""`firenav sweep`: tuned on tuning seeds, checked on report seeds; a failing cell is
reported and costs nothing else; an interrupted sweep resumes where it stopped."""
from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
import time

import pytest

from firenav_framework.cli import main
from firenav_framework.evaluation import evaluate
from firenav_framework.evaluation.sweep import load_sweep
from firenav_framework.yaml_locations import ConfigError

from .test_evaluate import INS

SWEEP = """\
name: tiny
pipelines: [still.yaml]
grid:
  sources.sim.duration: [35, 3]     # 3 s ends before the INS has aligned: no poses
seeds: {tuning: "100-101", report: "1000-1001"}
baseline: {path: still.yaml, set: ["estimators.ins.alignment.gyro_bias=false"]}
"""


@pytest.fixture
def folder(tmp_path):
    (tmp_path / "still.yaml").write_text(INS.format(name="still", still="true"))
    return tmp_path


def test_sweep_with_a_failing_cell(folder, capsys):
    (folder / "sweep.yaml").write_text(SWEEP)
    out = folder / "out"
    assert main(["sweep", str(folder / "sweep.yaml"), "--output", str(out), "--quiet"]) == 1
    rows = list(csv.DictReader((out / "results.csv").open()))
    pooled = [r for r in rows if r["agent"] == "all"]
    # 2 settings x 2 tuning seeds, then the best and the baseline on 2 report seeds
    assert [(r["phase"], r["setting"], r["seed"]) for r in pooled] == [
        ("tuning", "s001", "100"), ("tuning", "s001", "101"),
        ("tuning", "s002", "100"), ("tuning", "s002", "101"),
        ("report", "s001", "1000"), ("report", "s001", "1001"),
        ("baseline", "baseline", "1000"), ("baseline", "baseline", "1001")]
    failed = [r for r in pooled if r["ok"] == "False"]
    assert [(r["setting"], r["seed"], r["attempts"]) for r in failed] == [
        ("s002", "100", "2"), ("s002", "101", "2")]
    assert all("no poses on 'dr.pose'" in r["error"] for r in failed)
    # the cells that ran have the figures `evaluate` gives for the same runs
    direct = evaluate(folder / "still.yaml", seeds=[100, 101],
                      overrides=["sources.sim.duration=35"])
    for r, run in zip(pooled[:2], direct.runs):
        assert float(r["rmse_m"]) == pytest.approx(run.figures.rmse_m, rel=1e-12)
    report = (out / "report.md").read_text()
    assert "| 1 | still | s001 | `sources.sim.duration=35` | 2 | 0 |" in report
    assert "| - | still | s002 | `sources.sim.duration=3` | 0 | 2 |" in report
    assert "Use with: `--set sources.sim.duration=35`" in report
    assert "| tuning | still | s002 |  | 101 | 2 | EvaluationError: the run produced no poses" \
        in report
    assert "baseline `still` (2 runs)" in report
    assert "still s001 sources.sim.duration=35: rmse_m median" in capsys.readouterr().out


def test_random_search_and_bad_sweep_files(folder):
    f = folder / "random.yaml"
    f.write_text("pipelines: [still.yaml]\nrandom:\n  samples: 5\n  seed: 3\n  params:\n"
                 "    estimators.ins.alignment.duration: {uniform: [5.0, 9.0]}\n"
                 "    estimators.dr.alignment: {choice: [pose, none]}\n"
                 "seeds: {tuning: '100-102', report: null}\n")
    a, b = load_sweep(f), load_sweep(f)
    assert a.settings == b.settings and len(a.settings) == 5         # drawn from its seed
    assert all(5.0 <= dict(s.params)["estimators.ins.alignment.duration"] <= 9.0
               for s in a.settings)
    assert a.report_seeds == [] and a.goal == "min"
    f.write_text("pipelines: [still.yaml]\ngird: {x: [1]}\n")
    with pytest.raises(ConfigError) as exc:
        load_sweep(f)
    assert f"{f}:2:1: gird: unknown parameter" in str(exc.value)
    f.write_text("pipelines: [still.yaml]\nseeds: {tuning: '100-110', report: '110-120'}\n")
    with pytest.raises(ConfigError, match="tuning and report seeds overlap"):
        load_sweep(f)
    f.write_text("pipelines: [nowhere.yaml]\n")
    with pytest.raises(ConfigError, match="nowhere.yaml not found"):
        load_sweep(f)
    f.write_text("pipelines: [still.yaml]\ngrid: {estimators.ins.particles: [1]}\n")
    assert main(["sweep", str(f), "--output", str(folder / "o"), "--quiet"]) == 2


def test_interrupted_sweep_resumes_where_it_stopped(folder, repo):
    (folder / "sweep.yaml").write_text(
        "name: resume\npipelines: [still.yaml]\n"
        "grid: {estimators.ins.alignment.gyro_bias: [true, false]}\n"
        "seeds: {tuning: '100-103', report: null}\n")
    out = folder / "out"
    journal = out / "results.jsonl"
    env = dict(os.environ, PYTHONPATH=str(repo))
    proc = subprocess.Popen([sys.executable, "-m", "firenav_framework", "sweep",
                             str(folder / "sweep.yaml"), "--output", str(out), "--quiet"],
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None:
        if journal.exists() and journal.read_text().count("\n") >= 2:
            break
        time.sleep(0.05)
    assert proc.poll() is None, "the sweep ended before it could be interrupted"
    proc.send_signal(signal.SIGKILL)                 # no chance to clean up
    proc.wait(30)
    before = [json.loads(line)["key"] for line in journal.read_text().splitlines()
              if line.endswith("}")]
    assert 2 <= len(before) < 8
    assert main(["sweep", str(folder / "sweep.yaml"), "--output", str(out), "--quiet"]) == 0
    keys = [json.loads(line)["key"] for line in journal.read_text().splitlines()
            if line.strip().endswith("}")]
    assert keys[:len(before)] == before                  # kept, not run again
    assert len(keys) == 8 and len(set(keys)) == 8        # the rest ran exactly once
    rows = [r for r in csv.DictReader((out / "results.csv").open()) if r["agent"] == "all"]
    assert len(rows) == 8 and all(r["ok"] == "True" for r in rows)
