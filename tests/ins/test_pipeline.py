"""`firenav run pipelines/foot-ins.yaml --input FILE` on a file of each real dataset."""
from __future__ import annotations

import csv

import pytest

from firenav_framework.cli import main


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
    assert len(poses) > 20 and len(states) > 10 * len(poses) / 3
    assert all(p["agent"] == "ff1" for p in poses)
    # the track leaves the start: metres travelled in the INS frame
    assert max(abs(float(p["x"])) + abs(float(p["y"])) for p in poses) > 1.0
    assert (tmp_path / "tracks.png").is_file() and (tmp_path / "tracks.geojson").is_file()
