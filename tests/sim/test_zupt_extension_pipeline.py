"""The ZUPT-extension paper's method as published (pipelines/zupt-extension-as-published.yaml)
and the overrides benchmarks/bench_baselines.py --zupt-extension switches it off with."""
from __future__ import annotations

import sys

from firenav_framework.pipeline import load_pipeline


def test_the_as_published_pipeline_has_the_extension_on_and_the_benchmark_turns_it_off(repo):
    sys.path.insert(0, str(repo / "benchmarks"))
    from bench_baselines import AS_PUBLISHED, EXTENSION_OFF
    on = load_pipeline(AS_PUBLISHED).by_id("ins").params
    off = load_pipeline(AS_PUBLISHED, EXTENSION_OFF).by_id("ins").params
    assert on.height.correction and on.outputs.retrospective_correction
    assert not off.height.correction and not off.outputs.retrospective_correction
    # the paper's rules only: none of firenav's additions
    for p in (on, off):
        assert not p.alignment.gyro_bias and not p.zaru.enabled and not p.filter.bias_states
    assert on.model_dump(exclude={"height", "outputs"}) == off.model_dump(
        exclude={"height", "outputs"})
    assert on.height.model_dump(exclude={"correction"}) == off.height.model_dump(
        exclude={"correction"})
