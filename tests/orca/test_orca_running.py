"""Issue 15's ORCA failure: running at 3 m/s (field_corridor_run, anchor out of line of
sight). The paper's fixed 2.5 m/s wrong-compartment test reset the track to the INS on
most wall contacts (7-15 resets a run on these seeds); the speed-aware test does not, the
track stays out of the walls and beats INS alone; and INS alone, the baseline every map
pipeline is measured against, is honest about its own drift. Tuning seeds only."""
from __future__ import annotations

import pytest

from firenav_framework.evaluation.runs import evaluate
from firenav_framework.pipeline import load_pipeline
from firenav_framework.runner import run_pipeline

SEEDS = (100, 101)


@pytest.fixture(scope="module")
def runs(repo):
    out = []
    for seed in SEEDS:
        spec = load_pipeline(repo / "pipelines" / "orca-map-matching.yaml",
                             ["sources.sim.scenario=field_corridor_run",
                              f"sources.sim.seed={seed}"])
        out.append(run_pipeline(spec))
    return out


def test_running_is_not_taken_for_a_wrong_compartment(runs):
    for run in runs:
        assert run.faults == []
        assert run.stats.counts.get("mm", {}).get("orca_reset", 0) <= 2


def test_the_running_track_never_goes_through_a_wall(runs):
    for run in runs:
        track = run.tracks["mm.pose"]["ff1"]
        floor = run.building.floors[0]
        assert not floor.crosses_wall(track.position[:-1, :2], track.position[1:, :2]).any()


def test_running_beats_ins_alone_and_is_never_trusted_while_off(repo):
    kw = dict(scenario="field_corridor_run", seeds=list(SEEDS))
    ours = evaluate(repo / "pipelines" / "orca-map-matching.yaml", **kw)
    ins = evaluate(repo / "pipelines" / "ins-baseline.yaml", **kw)
    for a, b in zip(ours.runs, ins.runs):
        (m,), (n,) = a.metrics.values(), b.metrics.values()
        assert m.rmse_m < 0.7 * n.rmse_m
        assert m.trusted_off_fraction <= 0.02
        assert m.ellipse95_containment >= 0.9


def test_ins_alone_covariance_holds_its_drift(repo):
    """The 95 % ellipse of INS alone holds the truth about 95 % of the time and no pose is
    trusted while more than 3 m off (before its drift states: 0.83 and 13 % on these
    seeds)."""
    ins = evaluate(repo / "pipelines" / "ins-baseline.yaml", scenario="field_corridor_run",
                   seeds=[100, 101, 102, 103]).overall
    assert ins.ellipse95_containment >= 0.9
    assert ins.trusted_off_fraction <= 0.02
    assert 0.5 < ins.nees_xy < 4.0
