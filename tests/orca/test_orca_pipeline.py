"""The bundled ORCA pipeline end to end on the simulator's Test III (through a room)."""
from __future__ import annotations

import numpy as np
import pytest

from firenav_framework.evaluation.runs import evaluate
from firenav_framework.pipeline import load_pipeline
from firenav_framework.runner import run_pipeline


@pytest.fixture(scope="module")
def run(repo):
    spec = load_pipeline(repo / "pipelines" / "orca-map-matching.yaml",
                         ["sources.sim.scenario=orca_test3", "sources.sim.seed=0"])
    return run_pipeline(spec)


def test_every_ins_step_is_placed_without_faults(run):
    assert run.faults == []
    n_steps = run.stats.messages["ins.odometry"]
    assert n_steps > 50
    assert len(run.tracks["mm.pose"]["ff1"]) == n_steps
    assert run.stats.messages["uwb.range"] > 0
    assert "ranges_unknown_anchor" not in run.stats.counts.get("orca", {})


def test_corrected_track_only_passes_walls_where_a_reset_put_it(run):
    """ORCA keeps the agent out of walls; only the wrong-compartment reset may jump one."""
    track = run.tracks["mm.pose"]["ff1"]
    floor = run.building.floors[0]
    crossings = int(floor.crosses_wall(track.position[:-1, :2], track.position[1:, :2]).sum())
    resets = run.stats.counts.get("mm", {}).get("orca_reset", 0)
    assert crossings <= resets


def test_walls_and_ranges_hold_the_covariance(run):
    """The drift states make the covariance grow (test_dead_reckoning.py); here the walls
    around the track and the anchor's ranges are fused into it, so it stays bounded and
    every pose but the jumped ones is within the alert limit; the heading variance still
    grows while nothing measures the position. The radius it gives holds the true error
    (simulator truth) on every pose."""
    track = run.tracks["mm.pose"]["ff1"]
    assert run.stats.counts["mm"]["position_updates"] > len(track.t)
    radius = track.protection_radius
    assert np.median(radius) < 3.0                 # integrity.alert_limit
    assert np.mean(track.trusted) > 0.8
    truth = run.truth["ff1"]
    true_xy = np.column_stack([np.interp(track.t, truth.t, truth.position[:, i]) for i in (0, 1)])
    assert np.all(np.hypot(*(track.position[:, :2] - true_xy).T) <= radius)


def test_every_rule_of_the_bundled_pipeline_acts(run):
    counts = run.stats.counts
    assert counts["anchor_range"]["ranges_used"] > 20
    for event in ("anchor_range", "wall_follow"):
        assert counts["mm"][event] > 0


def test_beats_ins_alone_at_the_check_points_of_test_ii(repo):
    """Along one corridor wall and back along the other (simulator ground truth, one
    seed; benchmarks/bench_orca_corridor.py gives the 10-seed figures): the corrected
    track is at least twice as close to the check points as the same INS alone."""
    kw = dict(scenario="orca_test2", seeds=[3], truth_mode="checkpoints")
    ours = evaluate(repo / "pipelines" / "orca-map-matching.yaml", **kw).overall
    ins = evaluate(repo / "pipelines" / "ins-baseline.yaml", **kw).overall
    assert ours.rmse_m < 0.5 * ins.rmse_m
    assert ours.max_m < ins.max_m


def test_through_the_room_of_test_iii_it_stays_close(repo):
    """Test III, the seed where a turn into a table once dragged the whole path 3 m off
    (a translation per held step, hiding the wrong compartment from the reset rule):
    the corrected track stays within half the INS alone's check-point RMSE."""
    kw = dict(scenario="orca_test3", seeds=[1], truth_mode="checkpoints")
    ours = evaluate(repo / "pipelines" / "orca-map-matching.yaml", **kw).overall
    ins = evaluate(repo / "pipelines" / "ins-baseline.yaml", **kw).overall
    assert ours.rmse_m < 0.5 * ins.rmse_m
    assert ours.max_m < 0.5 * ins.max_m


def test_the_pipeline_sets_the_papers_angles_in_degrees(repo):
    """The pipeline writes the §2.2 thresholds as '2 deg' ...; the constraint reads the
    same angles in radians (2, 30, 90 and 15 degrees)."""
    orca = load_pipeline(repo / "pipelines" / "orca-map-matching.yaml").by_id("orca").params
    assert (orca.min_rotation, orca.max_rotation, orca.door_angle, orca.door_tolerance) == \
        pytest.approx((np.pi / 90, np.pi / 6, np.pi / 2, np.pi / 12), rel=1e-15)
