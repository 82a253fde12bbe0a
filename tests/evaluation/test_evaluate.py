"""`firenav evaluate`: a pipeline over seeds beside a baseline, JSON keys, report, real data."""
from __future__ import annotations

import json

import pytest

from firenav_framework.cli import main
from firenav_framework.evaluation import EvaluationError, evaluate
from firenav_framework.evaluation.report import write_report
from firenav_framework.scaleout import SerialExecutor, Task

INS = """\
name: {name}
sources:
  - {{id: sim, plugin: simulator, scenario: orca_test1, seed: 0, duration: 35}}
sensors:
  - {{id: imu, plugin: foot_imu, input: sim.imu}}
estimators:
  - {{id: ins, plugin: zupt_ins, input: imu.imu, alignment: {{gyro_bias: {still}, duration: 8.0}}}}
  - id: dr
    plugin: dead_reckoning
    input: ins.odometry
    start: {{mode: pose, agents: {{ff1: {{position: [5.12, 8.3, 0.06], heading: 0.0}}}}}}
"""

KEYS = ["rmse_m", "mean_m", "median_m", "p90_m", "p95_m", "max_m", "mean_pct_distance",
        "max_pct_distance", "distance_m", "vertical_rmse_m", "floor_accuracy", "converge_s",
        "runs"]


@pytest.fixture(scope="module")
def pipelines(tmp_path_factory):
    d = tmp_path_factory.mktemp("pipes")
    good, raw = d / "still.yaml", d / "raw.yaml"
    good.write_text(INS.format(name="still", still="true"))
    raw.write_text(INS.format(name="raw", still="false"))
    return good, raw


def test_cli_evaluate_writes_the_json_keys_and_a_report(pipelines, tmp_path, capsys):
    good, raw = pipelines
    code = main(["evaluate", str(good), "--seeds", "2", "--baseline", str(raw),
                 "--json", str(tmp_path / "e.json"), "--report", str(tmp_path / "rep"),
                 "--quiet"])
    assert code == 0
    out = capsys.readouterr().out
    assert "pipeline" in out and "baseline" in out and "RMSE" in out
    doc = json.loads((tmp_path / "e.json").read_text())
    for key in KEYS:
        assert key in doc and key in doc["baseline"], key
    assert doc["runs"] == 2 and doc["seeds"] == [0, 1] and doc["stream"] == "dr.pose"
    assert doc["distance_m"] == pytest.approx(doc["baseline"]["distance_m"])   # same walks
    assert 12 < doc["distance_m"] < 30
    assert doc["floor_accuracy"] == 1.0
    assert [r["seed"] for r in doc["per_run"]] == [0, 1]
    # the standstill gyro calibration removes the turn-on bias: it must not be worse
    assert doc["rmse_m"] <= doc["baseline"]["rmse_m"] + 0.05
    rep = (tmp_path / "rep" / "report.md").read_text()
    assert "| RMSE [m] |" in rep and "baseline" in rep
    for png in ("error_time.png", "error_cdf.png", "tracks_seed0_floor0.png"):
        assert (tmp_path / "rep" / png).stat().st_size > 5000


def test_evaluate_uses_the_seeds_and_checkpoints(pipelines):
    good, _ = pipelines
    ev = evaluate(good, seeds=[3], truth_mode="checkpoints")
    run = ev.runs[0]
    assert run.seed == 3 and run.truth_mode == "checkpoints"
    err = run.errors["ff1"]
    # orca_test1 stops at P0..P2 within the first 35 s: one error per reached checkpoint
    assert 2 <= len(err.t) <= 4
    assert ev.summary()["truth_mode"] == "checkpoints"
    dense = evaluate(good, seeds=[3])
    assert len(dense.runs[0].errors["ff1"].t) > 3 * len(err.t)


def test_evaluate_refuses_what_it_cannot_do(pipelines, tmp_path):
    good, _ = pipelines
    with pytest.raises(EvaluationError, match="produced by nobody.*dr.pose"):
        evaluate(good, stream="nope.pose")
    with pytest.raises(EvaluationError, match="truth mode"):
        evaluate(good, truth_mode="psychic")
    rec = tmp_path / "rec.yaml"
    rec.write_text("sources:\n  - {id: rec, plugin: recording, path: x.csv}\n"
                   "sensors:\n  - {id: imu, plugin: foot_imu, input: rec.imu}\n"
                   "estimators:\n  - {id: ins, plugin: zupt_ins, input: imu.imu}\n")
    with pytest.raises(EvaluationError, match="several seeds need a 'simulator' source"):
        evaluate(rec, seeds=3)
    with pytest.raises(EvaluationError, match="--scenario needs"):
        evaluate(rec, scenario="demo")
    assert main(["evaluate", str(good), "--seeds", "x"]) == 2
    assert main(["evaluate", str(tmp_path / "none.yaml")]) == 2


def test_cli_refuses_a_bare_count_above_100_and_keeps_names_and_ranges(tmp_path, capsys):
    """The seeds are read before anything runs: a refused count is the error, an accepted
    one lets the next check (a pipeline that does not exist) answer."""
    missing = str(tmp_path / "none.yaml")
    assert main(["evaluate", missing, "--seeds", "1000"]) == 2
    err = capsys.readouterr().err
    assert "--seeds '1000'" in err and "1000-1000" in err and "0-999" in err
    for ok in ("tuning", "report", "fresh-report", "100", "1000-1000", "1000,1003"):
        assert main(["evaluate", missing, "--seeds", ok]) == 2
        assert "pipeline" in (err := capsys.readouterr().err) and "not found" in err, ok


def test_real_walk_is_evaluated_at_its_surveyed_strides(shared_data, repo, tmp_path):
    """Indoor walk 31: truth is one surveyed footprint per stride, in the survey frame."""
    walk = shared_data / "indoor-walks" / "walk_31.mat"
    pipe = repo / "pipelines" / "foot-ins.yaml"
    over = [f"sources.rec.path={walk}"]
    fitted = evaluate(pipe, overrides=over, stream="ins.pose", align="first:5")
    best = evaluate(pipe, overrides=over, stream="ins.pose", align="all")
    assert fitted.truth_mode == "sparse" and fitted.seeds == [None]
    f, b = fitted.overall, best.overall
    # the surveyed distance of walk 31 is about 48 m; the fitted INS stays within 1-2 %
    assert 40 < f.distance_m < 55 and f.n > 20
    assert f.mean_pct_distance < 2.0
    assert b.rmse_m <= f.rmse_m + 1e-9       # fitting on every checkpoint is optimistic


def _broken_run(run):
    raise RuntimeError(f"simulated crash of seed {run.seed}")


class CrashOnSeed1(SerialExecutor):
    """The serial executor, but the run of seed 1 crashes (as a buggy plugin would)."""

    def run(self, tasks, progress=None):
        tasks = [Task(t.key, t.label, _broken_run, t.args) if t.args[0].seed == 1 else t
                 for t in tasks]
        return super().run(tasks, progress)


def test_a_failed_run_is_reported_and_the_others_are_scored(pipelines, tmp_path):
    good, _ = pipelines
    ev = evaluate(good, seeds=3, executor=CrashOnSeed1())
    assert [r.seed for r in ev.runs] == [0, 2]
    assert [(f.seed, f.error, f.attempts) for f in ev.failed] == [
        (1, "RuntimeError: simulated crash of seed 1", 2)]
    alone = evaluate(good, seeds=[0, 2])
    assert ev.overall == alone.overall                  # the failure cost the others nothing
    doc = ev.summary()
    assert doc["failed"] == [{"seed": 1, "error": "RuntimeError: simulated crash of seed 1",
                              "attempts": 2}]
    assert doc["runs"] == 2 and doc["spread"]["rmse_m"]["n"] == 2
    rep = write_report(ev, tmp_path / "rep").read_text()
    assert "- seed 1 FAILED after 2 attempts (not scored): RuntimeError: simulated crash" in rep
