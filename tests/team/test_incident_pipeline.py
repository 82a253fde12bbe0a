"""pipelines/incident.yaml end to end on a short copy of the incident (tests/team/
incident_short.yaml, tuning seed 101, 200 particles): every method runs, team_fusion publishes a pose
for every firefighter, beats INS alone on the pooled error, keeps the floor, and says
when an input is left out."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from firenav_framework.evaluation.metrics import pooled_metrics, track_errors
from firenav_framework.pipeline import load_pipeline
from firenav_framework.runner import run_pipeline

# under a loaded machine the run can take minutes (about 20 s of CPU alone)
pytestmark = pytest.mark.timeout(900)

REPO = Path(__file__).resolve().parents[2]
SHORT = Path(__file__).with_name("incident_short.yaml")


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    spec = load_pipeline(REPO / "pipelines" / "incident.yaml",
                         [f"sources.sim.scenario={SHORT}", "sources.sim.seed=101", "sinks=[]",
                          "estimators.pf.particles=200"])
    return run_pipeline(spec, output_dir=tmp_path_factory.mktemp("incident"))


def _pooled(run, stream):
    levels = np.array([f.z for f in run.building.floors])
    errs = [track_errors(tr, run.truth[a], levels) for a, tr in run.tracks[stream].items()]
    return pooled_metrics(errs)


def test_every_method_and_the_fusion_run_for_their_crews(run):
    assert not run.faults
    agents = {"ff1", "ff2", "ff3", "ff4"}
    for stream in ("dr.pose", "pf.pose", "mm.pose", "ekf.pose", "gen.pose", "team.pose"):
        assert set(run.tracks[stream]) == agents, stream
    # the breadcrumb crew's radio ranged to its breadcrumbs and the base station
    assert run.stats.counts["gen"].get("range_thinned", 0) + \
        run.stats.counts["gen"].get("ranges_near", 0) > 0


def test_team_fusion_beats_ins_alone_and_keeps_the_floor(run):
    team, ins = _pooled(run, "team.pose"), _pooled(run, "dr.pose")
    assert team.rmse_m < ins.rmse_m
    assert team.p95_m < ins.p95_m
    assert team.floor_accuracy >= 0.98
    # every fused pose has a finite protection radius and trusted follows it
    for tr in run.tracks["team.pose"].values():
        assert np.all(np.isfinite(tr.protection_radius))
        assert not np.any(tr.trusted & (tr.protection_radius > 3.0))
