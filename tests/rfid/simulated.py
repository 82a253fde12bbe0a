"""Strides and barometer heights from the simulator, for the floor tests and benchmark.

One run of the simulator (its barometer model: firenav_framework/simulator/barometer.py),
a foot INS with its defaults (no still-start calibration) and the ``barometer`` sensor
with its defaults; the odometry and the heights are then fed to estimators under test
(both from the same run: an estimator with and one without the barometer see the same
strides).
"""
from __future__ import annotations

__all__ = ["simulated_inputs"]


def simulated_inputs(scenario: str, seed: int, *, imu_grade: str | None = None,
                     duration: float | None = None):
    """Run ``scenario`` (bundled name or file) with ``seed`` (every foot IMU of grade
    ``imu_grade`` when given, cut at ``duration`` [s] when given): (odometry messages
    in time order, PressureHeight messages in time order (none when the scenario has no
    barometer), truth per agent, building)."""
    from pathlib import Path

    import yaml

    from firenav_framework.pipeline import load_pipeline_text
    from firenav_framework.simulator import load_scenario
    from firenav_framework.sources.simulator import _scenario_path, scenario_ports

    from .harness import run_tapped

    sim = {"id": "sim", "plugin": "simulator", "scenario": str(scenario), "seed": seed}
    if imu_grade:
        sim["imu_grade"] = imu_grade
    if duration:
        sim["duration"] = duration
    sensors = [{"id": "imu", "plugin": "foot_imu", "input": "sim.imu"}]
    has_baro = "baro" in scenario_ports(load_scenario(_scenario_path(str(scenario), Path.cwd())))
    if has_baro:
        sensors.append({"id": "baro", "plugin": "barometer", "input": "sim.baro"})
    spec = load_pipeline_text(yaml.safe_dump({
        "name": "strides", "sources": [sim], "sensors": sensors,
        "estimators": [{"id": "ins", "plugin": "zupt_ins", "input": "imu.imu"}],
        "sinks": []}), file=f"<strides {scenario} {seed}>")
    result, seen = run_tapped(spec, ("ins.odometry", "baro.height"))
    return (sorted(seen["ins.odometry"], key=lambda m: m.t),
            sorted(seen.get("baro.height", []), key=lambda m: m.t), result.truth,
            result.building)
