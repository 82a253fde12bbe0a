"""`firenav evaluate` on a LocalCluster (2 processes, loopback) gives, run for run, the
very figures and tracks of the serial evaluation of the same seeds."""
from __future__ import annotations

import json

import numpy as np

from firenav_framework.cli import main
from firenav_framework.evaluation import evaluate

INS = """\
name: ins-short
sources:
  - {id: sim, plugin: simulator, scenario: orca_test1, seed: 0, duration: 35}
sensors:
  - {id: imu, plugin: foot_imu, input: sim.imu}
estimators:
  - {id: ins, plugin: zupt_ins, input: imu.imu, alignment: {gyro_bias: true, duration: 8.0}}
  - id: dr
    plugin: dead_reckoning
    input: ins.odometry
    start: {mode: pose, agents: {ff1: {position: [5.12, 8.3, 0.06], heading: 0.0}}}
"""


def _same_runs(a, b) -> None:
    assert [r.seed for r in a.runs] == [r.seed for r in b.runs]
    for ra, rb in zip(a.runs, b.runs):
        assert sorted(ra.tracks) == sorted(rb.tracks)
        for agent in ra.tracks:
            ta, tb = ra.tracks[agent], rb.tracks[agent]
            assert np.array_equal(ta.t, tb.t), (ra.seed, agent)
            assert np.array_equal(ta.position, tb.position), (ra.seed, agent)
            assert np.array_equal(ta.cov, tb.cov, equal_nan=True), (ra.seed, agent)
        assert ra.figures == rb.figures
    assert a.overall == b.overall and a.per_agent == b.per_agent


def test_particle_filter_on_the_cluster_equals_serial(cluster, repo):
    """The PF (random generators per agent, numba's parallel ICP) is a pure function of
    its inputs: other processes, other thread counts, other task order, same numbers."""
    # 120 s of search: long enough for the first search-pattern (ICP) comparisons
    kw = dict(seeds=[101, 102, 103], overrides=["sources.sim.duration=120"])
    pipe = repo / "pipelines" / "search-pattern-pf.yaml"
    serial = evaluate(pipe, **kw)
    parallel = evaluate(pipe, executor=cluster, **kw)
    _same_runs(serial, parallel)
    assert serial.overall.n > 20


def test_cli_evaluate_with_workers_writes_the_serial_json(tmp_path):
    pipe = tmp_path / "ins.yaml"
    pipe.write_text(INS)
    docs = []
    for extra in ([], ["--workers", "2"]):
        out = tmp_path / f"e{len(docs)}.json"
        assert main(["evaluate", str(pipe), "--seeds", "100-103", "--baseline", str(pipe),
                     "--baseline-set", "estimators.ins.alignment.gyro_bias=false",
                     "--json", str(out), "--quiet", *extra]) == 0
        doc = json.loads(out.read_text())
        for part in (doc, doc["baseline"]):
            for r in part["per_run"]:
                del r["wall_s"], r["cpu_s"]          # timings differ, nothing else may
        docs.append(doc)
    assert docs[0] == docs[1]
    assert docs[0]["seeds"] == [100, 101, 102, 103] and docs[0]["seed_set"] == "part of tuning"
    assert len(docs[0]["per_run"]) == 4 and docs[0]["spread"]["rmse_m"]["n"] == 4
