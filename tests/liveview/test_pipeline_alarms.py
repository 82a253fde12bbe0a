"""A real pipeline run: the live view's alarms reach diagnostics_log and mcap_recorder
through its diagnostics stream, as the field pipelines wire them."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from firenav_framework.pipeline import load_pipeline_text
from firenav_framework.runner import run_pipeline
from firenav_framework.simulator import load_scenario, simulate

SCENARIO = Path(__file__).with_name("data") / "man_down.yaml"
PIPELINE = f"""
name: man-down
sources: [{{id: sim, plugin: simulator, scenario: {SCENARIO}, seed: 0}}]
sensors: [{{id: imu, plugin: foot_imu, input: sim.imu}}]
estimators: [{{id: ins, plugin: zupt_ins, input: imu.imu}}]
sinks:
  - {{plugin: live_view, port: 0, input: [ins.pose, ins.diagnostics]}}
  - {{plugin: diagnostics_log, input: [ins.diagnostics, live_view.diagnostics]}}
  - {{plugin: mcap_recorder, input: [ins.pose, live_view.diagnostics]}}
"""


def test_man_down_reaches_the_incident_log_of_a_run(tmp_path):
    result = run_pipeline(load_pipeline_text(PIPELINE, base_dir=tmp_path), output_dir=tmp_path)
    assert not result.faults
    truth = simulate(load_scenario(SCENARIO), 0).truth["ff1"]
    moving = np.flatnonzero(np.linalg.norm(np.diff(truth.position[:, :2], axis=0), axis=1)
                            / np.diff(truth.t) > 0.2)
    stopped = truth.t[moving[-1] + 1]  # the walk's end, by the simulator
    lines = [json.loads(ln) for ln in (tmp_path / "diagnostics.jsonl").read_text().splitlines()]
    alarms = [ln for ln in lines if ln["code"] == "alarm_man_down"]
    assert len(alarms) == 1 and alarms[0]["agent"] == "ff1" and alarms[0]["active"]
    # raised 30 s (NFPA 1982) after the last motion over 0.5 m (the last half metre of
    # the walk is 0.4 s), both read on the timeline's 1 s ticks (up to 1 s late each)
    assert 28.5 <= alarms[0]["t"] - stopped <= 31.0
    assert alarms[0]["when"] == f"t={alarms[0]['t']:.1f} s" and alarms[0]["wall"]
    assert alarms[0]["stream"] == "live_view.diagnostics"
    from mcap.reader import make_reader
    with open(tmp_path / "fused.mcap", "rb") as fh:
        logged = [json.loads(m.data) for _, ch, m in make_reader(fh).iter_messages()
                  if ch.topic == "/incident_log"]
    assert [(e["code"], e["agent"]) for e in logged] == [("alarm_man_down", "ff1")]
    assert logged[0]["wall"] and logged[0]["text"] == alarms[0]["text"]
