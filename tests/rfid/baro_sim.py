"""A worn barometer's heights along a simulated walk, for the floor tests and benchmark.

The bundled simulator has no barometer model (no scenario carries one), so the heights
the ``barometer`` sensor would publish (``PressureHeight``, docs/barometer.md) are made
here from the truth, with every error that page lists for the fused height:

* the zeroing's error (the entrance reading vs. the reference), constant per run;
* the indoor offset that zeroing cannot remove (fire, open doors, ventilation, the stack
  effect): an Ornstein-Uhlenbeck process of ``indoor_sigma`` (0.85 m = 10 Pa) and time
  constant ``indoor_tau``, zero at the zeroing (it is what changes after);
* the stairwell's own pressure: an offset of ``step_sigma`` drawn per stair visit,
  on from entering the stairs to leaving them;
* weather left over while the reference is heard: a slow linear drift;
* reading noise over each report's interval.

Heights come every ``period`` (0.5 s, the sensor's default) from ``t_zero`` on (the
sensor publishes only once zeroed).
"""
from __future__ import annotations

import numpy as np

from firenav_framework.messages import PressureHeight

__all__ = ["baro_heights"]


def baro_heights(truth, agent: str, rng: np.random.Generator, *, period: float = 0.5,
                 t_zero: float = 10.0, zero_sigma: float = 0.3, indoor_sigma: float = 0.85,
                 indoor_tau: float = 300.0, step_sigma: float = 0.4,
                 drift: float = 0.002, noise: float = 0.1,
                 sigma: float = 0.9) -> list[PressureHeight]:
    """PressureHeight messages [m, building z] of ``agent`` along ``truth`` (a Track
    with ``t`` (N,) [s] and ``position`` (N, 3) [m]); see the module docstring. A
    stair visit is where the true height changes (gaps under 5 s closed)."""
    t = np.arange(truth.t[0] + t_zero, truth.t[-1], period)
    z = np.interp(t, truth.t, truth.position[:, 2])
    climbing = np.abs(np.gradient(z, t)) > 0.05
    # a stair visit: climbing with gaps under 5 s closed (landings, strides)
    k = int(round(5.0 / period))
    on_stair = np.convolve(climbing, np.ones(2 * k + 1), "same") > 0
    steps = np.zeros(len(t))
    edges = np.flatnonzero(np.diff(np.concatenate([[0], on_stair.astype(int), [0]])))
    for a, b in zip(edges[::2], edges[1::2]):
        steps[a:b] = rng.normal(0.0, step_sigma)
    a = np.exp(-period / indoor_tau)
    indoor = np.empty(len(t))
    x = 0.0
    for k in range(len(t)):
        indoor[k] = x
        x = a * x + np.sqrt(1 - a * a) * indoor_sigma * rng.normal()
    err = (rng.normal(0.0, zero_sigma) + indoor + steps
           + drift * rng.choice([-1.0, 1.0]) * (t - t[0]) + rng.normal(0.0, noise, len(t)))
    return [PressureHeight(t=float(tk), agent=agent, device=f"{agent}/baro",
                           height=float(zk + ek), sigma=sigma, pressure=101325.0,
                           reference_pressure=101325.0, interval=period)
            for tk, zk, ek in zip(t, z, err)]


def simulated_strides(scenario: str, seed: int, imu_errors: str | None = None):
    """Run the simulator and a foot INS with its defaults (no still-start calibration)
    on ``scenario`` (bundled name or file) and ``seed``: (odometry messages in time
    order, truth per agent, building). The strides are fed to estimators under test
    together with :func:`baro_heights`."""
    import yaml

    from firenav_framework.pipeline import load_pipeline_text

    from .harness import run_tapped

    sim = {"id": "sim", "plugin": "simulator", "scenario": str(scenario), "seed": seed}
    if imu_errors:
        sim["imu_errors"] = imu_errors
    spec = load_pipeline_text(yaml.safe_dump({
        "name": "strides", "sources": [sim],
        "sensors": [{"id": "imu", "plugin": "foot_imu", "input": "sim.imu"}],
        "estimators": [{"id": "ins", "plugin": "zupt_ins", "input": "imu.imu"}],
        "sinks": []}), file=f"<strides {scenario} {seed}>")
    result, seen = run_tapped(spec, ("ins.odometry",))
    return sorted(seen["ins.odometry"], key=lambda m: m.t), result.truth, result.building
