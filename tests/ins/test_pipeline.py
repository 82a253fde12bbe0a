"""`firenav run pipelines/foot-ins.yaml --input FILE` on a file of each real dataset."""
from __future__ import annotations

import csv

import numpy as np
import pytest

from firenav_framework.cli import main
from firenav_framework.sources.readers.foot_imu_datasets import load_indoor_walk, load_vicon_trial
from firenav_plugins.estimators.zupt_ins.metrics import path_length


@pytest.mark.parametrize("recording", ["indoor-walks/walk_34.mat",
                                       "pyshoe-vicon/2018-02-22-10-10-56.mat"])
def test_foot_ins_pipeline_writes_the_track(recording, shared_data, repo, tmp_path, capsys):
    code = main(["run", str(repo / "pipelines" / "foot-ins.yaml"), "--input",
                 str(shared_data / recording), "--output", str(tmp_path), "--quiet"])
    assert code == 0, capsys.readouterr().err
    with open(tmp_path / "ins_pose.csv") as fh:
        poses = list(csv.DictReader(fh))
    with open(tmp_path / "ins_state.csv") as fh:
        states = list(csv.DictReader(fh))
    assert len(poses) > 10 and len(states) > 10 * len(poses) / 3
    assert all(p["agent"] == "ff1" for p in poses)
    # the step poses travel the distance the truth travelled between them (crawling too)
    xy = np.array([[float(p["x"]), float(p["y"])] for p in poses])
    times = np.array([float(p["t"]) for p in poses])
    assert path_length(xy) == pytest.approx(_true_path(shared_data / recording, times), rel=0.15)
    assert (tmp_path / "tracks.png").is_file() and (tmp_path / "tracks.geojson").is_file()


def _true_path(path, times: np.ndarray) -> float:
    """Horizontal path [m] of a recording's truth: the surveyed strides, or VICON from one
    step time to the next."""
    if path.parent.name == "indoor-walks":
        return path_length(load_indoor_walk(path).gcp)
    tr = load_vicon_trial(path)
    return path_length(np.column_stack([np.interp(times, tr.ts, tr.gt[:, i]) for i in (0, 1)]))
