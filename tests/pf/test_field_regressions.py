"""Regressions of issue 15's particle-filter failures, on short copies of field scenarios.

Each test runs a bundled pipeline on the first minutes of a field scenario (one tuning
seed; the simulator's truth is the reference) beside INS alone on the same run, through
the evaluation behind ``firenav evaluate``:

* a plan with a door drawn as a wall, a door moved and a room split
  (``field_flat_wrong_plan``): from the known start, the filter of the paper's flat
  (walls remove particles, 0.12 m time-update noise) had an RMSE of 2.6 m over these
  4 minutes of seed 100, no protection radius, and was trusted while more than 3 m off
  23 % of the time (over the whole run: 4.3 m, INS alone 1.3 m);
* a search crawled on hands and knees (``field_crawl_search``): the crawling INS's
  heading is poor; the cloud, moved with the walking noise, stayed in the first room
  and was trusted while more than 3 m off 58 % of the first 5 minutes of seed 101;
* a consumer IMU never calibrated (``field_flat_consumer``, tuning seed 107, whole run):
  without a heading-drift state and with only the look-alike jump rule, the cloud
  followed the drifting odometry into the wrong rooms, tight, and was trusted while more
  than 3 m off 29.7 % of the run.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from firenav_framework.evaluation.runs import plan_evaluation, run_one

PIPELINES = Path(__file__).resolve().parents[2] / "pipelines"
FIELD = PIPELINES / "search-pattern-pf-field.yaml"
INS = PIPELINES / "ins-baseline.yaml"


def measured(pipeline: Path, scenario: str, seed: int, duration_s: float | None, stream=None):
    """The one agent's TrackErrors of ``pipeline`` on the first ``duration_s`` of a run
    (None: the whole run)."""
    plan = plan_evaluation(pipeline, scenario=scenario, seeds=[seed], stream=stream,
                           overrides=[f"sources.sim.duration={duration_s}"] if duration_s else [])
    (err,) = run_one(plan.runs[0]).errors.values()
    return err


def rmse(err) -> float:
    return float(np.sqrt(np.mean(err.horizontal ** 2)))


@pytest.fixture(scope="module")
def wrong_plan():
    return (measured(FIELD, "field_flat_wrong_plan", 100, 240.0),
            measured(INS, "field_flat_wrong_plan", 100, 240.0))


def test_wrong_plan_known_start_beats_ins_alone(wrong_plan):
    pf, ins = wrong_plan
    assert rmse(ins) > 0.8                    # the INS really drifts on this run
    assert rmse(pf) < 0.7 * rmse(ins)         # the 30 % margin


def test_wrong_plan_pose_carries_an_honest_protection_radius(wrong_plan):
    pf, _ = wrong_plan
    finite = np.isfinite(pf.protection)
    assert finite.mean() > 0.9
    assert np.mean(pf.horizontal[finite] <= pf.protection[finite]) >= 0.95
    assert np.mean(pf.trusted & (pf.horizontal > 3.0)) <= 0.02
    # and it is not simply never trusted (0.49 since the doubt rules of issue 15 round 4,
    # which halve the share trusted on the tuning runs: docs/particle-filter.md)
    assert pf.trusted.mean() > 0.4


def test_crawl_is_not_trusted_while_off():
    pf = measured(FIELD, "field_crawl_search", 101, 300.0)
    # the crawl leads it astray (5-9 m with the first crawl detector, 2-3 m with the
    # averaged one, 2.0 m with the crawl levels chosen on the VICON tuning half)
    assert np.max(pf.horizontal) > 1.5
    assert np.mean(pf.trusted & (pf.horizontal > 3.0)) <= 0.02
    finite = np.isfinite(pf.protection)       # and the radius it gives holds the error
    assert np.mean(pf.horizontal[finite] <= pf.protection[finite]) >= 0.95


def test_consumer_imu_is_not_trusted_while_off():
    pf = measured(FIELD, "field_flat_consumer", 107, None)
    ins = measured(INS, "field_flat_consumer", 107, None)
    assert rmse(pf) < rmse(ins)
    assert np.mean(pf.trusted & (pf.horizontal > 3.0)) <= 0.02
    # and it is not simply never trusted (0.41 before the doubt rules of issue 15 round 4,
    # 0.14 with them: on this run 3.6 m RMSE the filter is now trusted only early on)
    assert pf.trusted.mean() > 0.1
