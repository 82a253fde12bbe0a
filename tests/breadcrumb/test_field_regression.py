"""Regression (issue 15): "Breadcrumb GEN without the still-start calibration lost to PDR
alone". A short copy of the field loop (field_loop_short.yaml: two laps, an uncalibrated
consumer IMU with no still start, drawn radio, failing breadcrumbs) through the bundled
pipeline: on the seeds where the earlier GEN lost to PDR alone, GEN must beat PDR alone on
the same run and never be trusted while more than 3 m off."""
from __future__ import annotations

from pathlib import Path

import pytest

from firenav_framework.evaluation.metrics import metrics_of, track_errors
from firenav_framework.pipeline import load_pipeline
from firenav_framework.runner import run_pipeline

ROOT = Path(__file__).resolve().parents[2]
SCENARIO = Path(__file__).with_name("field_loop_short.yaml")
#: tuning seeds on which the GEN before this fix had a larger RMSE than PDR alone
LOST_SEEDS = (101, 103)


@pytest.mark.parametrize("seed", LOST_SEEDS)
def test_gen_without_still_start_beats_pdr_alone(seed, tmp_path):
    spec = load_pipeline(ROOT / "pipelines" / "breadcrumb-gen.yaml",
                         [f"sources.sim.seed={seed}", f"sources.sim.scenario={SCENARIO}",
                          "sinks=[]", "watchdog=0"])
    res = run_pipeline(spec, output_dir=tmp_path)
    gen = metrics_of(track_errors(res.tracks["gen.pose"]["ff1"], res.truth["ff1"]))
    pdr = metrics_of(track_errors(res.tracks["pdr.pose"]["ff1"], res.truth["ff1"]))
    assert gen.rmse_m < pdr.rmse_m
    assert gen.trusted_off_fraction <= 0.02
