"""Worker lanes and backpressure (firenav_framework/execution.py).

Lanes: a run on worker threads must publish exactly what the serial run publishes for
each firefighter, in each firefighter's order, the same messages in the same order in
every replay, faults contained as the serial bus contains them. Backpressure: a kit
that falls behind degrades one firefighter at a time, says so, and restores them once
it has caught up.
"""
from __future__ import annotations

import json

import numpy as np
import pytest

from firenav_framework import Diagnostic
from firenav_framework.execution import Backpressure
from firenav_framework.pipeline import load_pipeline_text
from firenav_framework.runner import run_pipeline

from tests.core.toys import Integrate, toy_registry


class LaneIntegrate(Integrate):
    """`integrate`, declared agents_independent (it keeps its state per firefighter)."""

    name = "lane_integrate"
    agents_independent = True


REG = toy_registry()
REG.add(LaneIntegrate, package="toys")
AGENTS = [f"ff{i}" for i in range(1, 7)]
STEPS = [[round(0.1 * k, 1), a, 1.0 + 0.01 * k + 0.1 * i]
         for k in range(1, 400) for i, a in enumerate(AGENTS)]


def pipeline(extra: str = "") -> str:
    return f"""
name: lanes
sources:
  - {{id: src, plugin: script, steps: {json.dumps(STEPS)}}}
estimators:
  - {{id: dr, plugin: lane_integrate, input: src.odo{extra}}}
sinks:
  - {{id: all, plugin: collect, input: "*"}}
"""


def run(tmp_path, workers: int, extra: str = ""):
    spec = load_pipeline_text(pipeline(extra), registry=REG, base_dir=tmp_path)
    return run_pipeline(spec, output_dir=tmp_path, workers=workers)


def published(res) -> list[tuple[str, str, float, tuple]]:
    return [(stream, m.agent, m.t, tuple(np.round(getattr(m, "position", np.zeros(3)), 12)))
            for stream, m in res.components["all"].got]


def per_agent(rows, agent):
    return [r for r in rows if r[1] == agent]


def test_workers_give_each_firefighter_the_serial_results_and_replays_are_identical(tmp_path):
    serial, a, b = run(tmp_path, 0), run(tmp_path, 2), run(tmp_path, 2)
    rows_s, rows_a, rows_b = published(serial), published(a), published(b)
    assert rows_a == rows_b                      # same messages, same order, every replay
    assert sorted(rows_a) == sorted(rows_s)      # nothing more, nothing less
    for agent in AGENTS:                         # each firefighter in its serial order
        assert per_agent(rows_a, agent) == per_agent(rows_s, agent)
    # the sink downstream of the lanes (it reads dr.pose) saw time order
    poses = [r[2] for r in rows_a if r[0] == "dr.pose"]
    assert len(poses) == len(STEPS) and poses == sorted(poses)
    for agent in AGENTS:
        np.testing.assert_allclose(a.tracks["dr.pose"][agent].position,
                                   serial.tracks["dr.pose"][agent].position, rtol=0, atol=0)


def test_a_fault_on_a_worker_is_contained_as_on_the_pipeline_thread(tmp_path):
    extra = ", fail_agent: ff3, fail_t: 4.0"
    serial, lanes = run(tmp_path, 0, extra), run(tmp_path, 2, extra)
    assert [(f.component, f.agent, f.t) for f in lanes.faults] == [("dr", "ff3", 4.0)]
    for agent in AGENTS:
        assert len(lanes.tracks["dr.pose"][agent]) == len(serial.tracks["dr.pose"][agent])
    assert len(lanes.tracks["dr.pose"]["ff3"]) == 39    # stopped at its failing step
    assert any(d.code == "plugin_fault" and d.agent == "ff3" for d in lanes.diagnostics)


def test_raise_policy_still_stops_the_run_from_a_worker(tmp_path):
    with pytest.raises(ValueError, match="scripted failure"):
        run(tmp_path, 2, ", fail_agent: ff3, fail_t: 4.0, on_error: raise")


class Degradable:
    def __init__(self):
        self.calls: list[tuple[str, int]] = []

    def degrade(self, agent: str, level: int) -> str:
        self.calls.append((agent, level))
        return f"level {level}"


def test_backpressure_degrades_one_firefighter_at_a_time_and_restores_them():
    comp, reports = Degradable(), []
    bp = Backpressure({"imu": comp, "other": object()}, reports.append,
                      behind_s=0.25, caught_up_s=0.05, hold_s=2.0)
    for agent in ("ff1", "ff2", "ff3"):
        bp.saw(agent)
    now = 0.0
    for _ in range(40):                 # 2 s of being 0.4 s behind
        bp.observe(0.4, now, t=now)
        now += 0.05
    assert comp.calls == [("ff3", 1), ("ff2", 1), ("ff1", 1)]   # one step per hold_s / 4
    assert [r.code for r in reports] == ["degraded"] * 3
    assert all(isinstance(r, Diagnostic) and r.active for r in reports)
    assert "0.40 s behind" in reports[0].text and "imu: level 1" in reports[0].text
    for _ in range(200):                # 10 s caught up
        bp.observe(0.01, now, t=now)
        now += 0.05
    assert comp.calls[3:] == [("ff1", 0), ("ff2", 0), ("ff3", 0)]  # reverse order
    assert [r.code for r in reports[3:]] == ["restored"] * 3 and not bp.degraded
    quiet = Backpressure({"x": object()}, reports.append)        # nothing to degrade
    quiet.saw("ff1")
    quiet.observe(5.0, 0.0, 0.0)
    assert len(reports) == 6

