"""The bundled pipelines of the particle filter load and validate (every parameter known)."""
from __future__ import annotations

from pathlib import Path

import pytest

from firenav_framework.pipeline import load_pipeline

PIPELINES = Path(__file__).resolve().parents[2] / "pipelines"


@pytest.mark.parametrize("name, overrides", [
    ("demo.yaml", []),
    ("search-pattern-pf.yaml", []),
    ("search-pattern-pf.yaml", ["estimators.pf.start.mode=truth",
                                "building=search-pattern-pf/flat_125_moved_door.geojson"]),
    ("search-pattern-pf-field.yaml", []),
    ("search-pattern-pf-as-published.yaml", []),
])
def test_bundled_pipeline_validates(name, overrides):
    spec = load_pipeline(PIPELINES / name, overrides)
    pf = spec.by_id("pf")
    assert pf.params.particles > 0
    if name == "search-pattern-pf-as-published.yaml":   # the paper's values (Sec. V-B)
        icp = spec.by_id("search_pattern_icp").params
        assert pf.params.particles == 500 and icp.sigma == 0.1 and icp.resample_above_m2 == 0
    if name == "demo.yaml":       # the demo's INS is uncalibrated: the filter carries the drift
        assert pf.params.motion.yaw_rate_sigma > 0 and not pf.params.motion.noise_while_still
