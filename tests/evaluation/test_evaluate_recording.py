"""`firenav evaluate PIPELINE --input RECORDING [--truth FILE]`: a recording with truth,
the estimate's frame fitted as stated."""
from __future__ import annotations

import json

import numpy as np
import pytest

from firenav_framework.cli import main
from firenav_framework.evaluation.checkpoints import Checkpoints, checkpoint_errors, parse_align
from firenav_framework.formats.base import imu_blocks
from firenav_framework.formats.imu_csv import write_imu_csv
from firenav_framework.sources.readers.foot_imu_datasets import load_vicon_trial
from firenav_framework.tracks import Track

WALK = "indoor-walks/walk_31.mat"
TRIAL = "pyshoe-vicon/2017-11-22-11-22-03.mat"


def evaluate(repo, tmp_path, *args) -> dict:
    out = tmp_path / f"ev{len(list(tmp_path.glob('ev*.json')))}.json"
    code = main(["evaluate", str(repo / "pipelines" / "foot-ins.yaml"), "--quiet",
                 "--json", str(out), *map(str, args)])
    assert code == 0
    return json.loads(out.read_text())


def test_a_recorded_walk_is_scored_at_its_surveyed_strides(shared_data, repo, tmp_path):
    """The INS frame is its own: fitted on the first 5 m it scores like the benchmark's
    fit on the first strides (0.58 %); fitted on everything it can only be better."""
    honest = evaluate(repo, tmp_path, "--input", shared_data / WALK)
    assert honest["truth_mode"] == "sparse" and honest["align"] == "first:5m"
    assert honest["distance_m"] == pytest.approx(47.9, abs=0.5)
    assert 0.3 < honest["mean_pct_distance"] < 1.5
    best = evaluate(repo, tmp_path, "--input", shared_data / WALK, "--align", "all")
    assert best["mean_m"] < honest["mean_m"]


def test_truth_from_another_file_gives_the_same_figures(shared_data, repo, tmp_path):
    """A VICON trial's IMU exported to CSV, its truth taken from the dataset file: the
    same figures as evaluating the dataset file itself."""
    tr = load_vicon_trial(shared_data / TRIAL)
    csv = write_imu_csv(tmp_path / "trial.csv", imu_blocks(tr.ts, tr.accel, tr.gyro,
                                                           block_s=10.0, agent="ff1",
                                                           device="ff1/imu"))
    direct = evaluate(repo, tmp_path, "--input", shared_data / TRIAL)
    via = evaluate(repo, tmp_path, "--input", csv, "--truth", shared_data / TRIAL)
    for key in ("rmse_m", "mean_m", "max_m", "distance_m"):
        assert via[key] == pytest.approx(direct[key], rel=1e-9), key


def test_a_truth_argument_that_is_neither_mode_nor_file_is_refused(shared_data, repo,
                                                                   capsys):
    code = main(["evaluate", str(repo / "pipelines" / "foot-ins.yaml"), "--input",
                 str(shared_data / WALK), "--truth", "survey"])
    assert code != 0
    assert "neither a truth mode" in capsys.readouterr().err


def test_alignment_on_the_first_metres():
    """first:Dm fits on the checkpoints of the first D metres of the truth's path."""
    assert parse_align("first:2.5m") == ("metres", 2.5)
    t = np.arange(6.0)
    truth = np.column_stack([t, np.zeros(6), np.zeros(6)])          # 1 m apart along x
    est = truth @ np.array([[0.0, 1, 0], [-1, 0, 0], [0, 0, 1]])    # turned by 90 deg
    est[4:, 1] += 0.5                                                # then off by 0.5 m
    track = Track("a", t, est, np.zeros(6), np.zeros((6, 4, 4)), np.full(6, -1),
                  np.ones(6, bool), np.full(6, np.inf))
    cps = Checkpoints("a", t, truth, np.full(6, -1))
    errors, outside = checkpoint_errors(track, cps, align="first:3m")
    assert outside == 0
    np.testing.assert_allclose(errors.horizontal, [0, 0, 0, 0, 0.5, 0.5], atol=1e-12)
