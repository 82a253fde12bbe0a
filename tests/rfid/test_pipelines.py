"""The bundled RFID pipelines: they validate, and the RFID route runs end to end."""
from __future__ import annotations

import numpy as np
import pytest

from firenav_framework.evaluation.metrics import track_errors
from firenav_framework.pipeline import load_pipeline
from firenav_framework.runner import run_pipeline

PIPELINES = ["rfid-ekf.yaml", "rfid-mems-baseline.yaml", "team.yaml"]


@pytest.mark.parametrize("name", PIPELINES)
def test_bundled_pipelines_validate(repo, name):
    spec = load_pipeline(repo / "pipelines" / name)
    assert any(c.plugin.name == "pdr_ekf" for c in spec.components)


def test_rfid_route_first_70_s(repo, tmp_path):
    """Simulated RFID route up to the first floor: every tag the first firefighter
    deployed is associated with the site it was really stuck on (the simulator knows),
    and the track and floor are right against the simulator's truth."""
    spec = load_pipeline(repo / "pipelines" / "rfid-ekf.yaml", ["sources.sim.duration=70"])
    result = run_pipeline(spec, output_dir=tmp_path)
    assert not result.faults
    placed = result.components["sim"].result.tags
    assert len(placed) >= 4
    db = result.components["ekf"].tags
    for tag_id, info in placed.items():
        assert db.lookup(tag_id).id == info["feature"].replace(":", "/"), tag_id
    err = track_errors(result.tracks["ekf.pose"]["ff1"], result.truth["ff1"])
    assert np.percentile(err.horizontal, 90) < 1.5
    assert np.nanmean(err.floor_ok) > 0.95
    assert (tmp_path / "ekf_pose.csv").is_file()
