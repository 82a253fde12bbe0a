"""The incident benchmark's ``--replay``: team_fusion on the recorded inputs of a run gives
the run's own team track, pose by pose (the tuning replays of docs/team-fusion.md rest on
it), and a changed setting changes it."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

pytestmark = pytest.mark.timeout(900)

REPO = Path(__file__).resolve().parents[2]
SHORT = Path(__file__).with_name("incident_short.yaml")
sys.path.insert(0, str(REPO / "benchmarks"))

import bench_team_incident as bench  # noqa: E402


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    spec = bench.ablation_pipeline(ablations=False)
    next(e for e in spec["estimators"] if e["id"] == "pf")["particles"] = 200
    path = tmp_path_factory.mktemp("replay") / "incident.yaml"
    path.write_text(yaml.safe_dump(spec))
    return bench.run_seed((str(path), 101, str(SHORT), True))


def test_replay_gives_the_pipelines_team_track(recorded):
    replayed = bench.replay(recorded["recording"], bench.team_params())
    agents = [a for (comp, a) in recorded["errors"] if comp == "team"]
    assert len(agents) == 4
    for agent in agents:
        live, again = recorded["errors"][("team", agent)], replayed[("team", agent)]
        assert np.array_equal(live.t, again.t)
        assert np.array_equal(live.horizontal, again.horizontal)


def test_a_changed_setting_changes_the_replay(recorded):
    base = bench.replay(recorded["recording"], bench.team_params())
    other = bench.replay(recorded["recording"],
                         bench.team_params(overrides=["inputs.mm.pose.inflate=50"]))
    assert any(not np.array_equal(base[k].horizontal, other[k].horizontal) for k in base)
