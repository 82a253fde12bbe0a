"""The ``simulator`` source: a scenario run played into a pipeline.

Ports (only those the scenario produces are declared): ``imu`` (ImuBlock per foot
IMU, device id ``<agent>/imu``, in the device axes the scenario declares, FLU by
default), ``uwb`` (Range, ``a=<agent>/uwb``, ``b=<anchor>``), ``rssi``
(RssiReading among breadcrumbs, base station and firefighters' radios), ``drops``
(BreadcrumbDrop), ``rfid`` (TagDetection), ``tags`` (TagDeployment), ``baro``
(RawFrame: every barometer's ``baro_lines`` on one serial link, for the ``barometer``
sensor), ``truth`` (GroundTruth per agent at the scenario's truth rate, with the floor).
The source brings the scenario's building, so map-aided plugins need no
``building:`` line: the plan the scenario gives the pipeline (its ``building``), never
the world the simulator walked when the scenario's ``world`` says the two differ
(docs/scenarios.md, "True world and given plan"); the truth comes from the world.
"""
from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

from pydantic import field_validator

from ..contract import Params, Source, param, pipeline_dir
from ..messages import (BreadcrumbDrop, Diagnostic, GroundTruth, ImuBlock, Message, Range,
                        RawFrame, RssiReading, TagDeployment, TagDetection)
from ..simulator.imu_grades import ImuErrors, get_grade
from ..yaml_locations import ConfigError

PORTS: dict[str, type[Message]] = {
    "imu": ImuBlock, "uwb": Range, "rssi": RssiReading, "drops": BreadcrumbDrop,
    "rfid": TagDetection, "tags": TagDeployment, "baro": RawFrame, "truth": GroundTruth,
}


def scenario_ports(scenario) -> set[str]:
    """The ports a scenario produces (truth always)."""
    m = scenario.model
    ports = {"truth"}
    if any(a.sensors.imu is not None for a in m.agents):
        ports.add("imu")
    if any(a.sensors.uwb is not None for a in m.agents):
        ports.add("uwb")
    if any(a.sensors.rfid is not None for a in m.agents):
        ports |= {"rfid", "tags"}
    if any(a.sensors.barometer is not None for a in m.agents):
        ports.add("baro")
    dispensers = any(a.sensors.dispenser is not None for a in m.agents)
    radios = [a for a in m.agents if a.sensors.radio]
    if dispensers or radios:
        ports |= {"rssi", "drops"} if dispensers else {"rssi"}
    return ports


class SimulatorSource(Source):
    """Simulate a scenario (bundled name or YAML file) and play its sensor streams."""

    name = "simulator"
    provides_building = True
    input_param = "scenario"

    class Params(Params):
        scenario: str = param("demo")
        """scenario file (relative to the pipeline file) or bundled scenario name; see `firenav
        simulate --list`"""
        seed: int = param(0, ge=0)
        """random seed: the same seed gives the same run"""
        duration: float | None = param(None, unit="s", gt=0)
        """stop after this long (default: the scenario's own end)"""
        block_s: float = param(0.1, unit="s", gt=0, le=10)
        """length of the ImuBlock pieces"""
        imu_errors: ImuErrors | None = param(None)
        """errors of every foot IMU, replacing the scenario's: as_worn, calibrated, datasheet or
        ideal (default: the scenario's own, as_worn unless it says)"""
        imu_grade: str | None = param(None)
        """grade of every foot IMU, replacing the scenario's (e.g. consumer: a consumer-IMU variant
        of the same walk)"""

        @field_validator("imu_grade")
        @classmethod
        def _known_grade(cls, v: str | None) -> str | None:
            if v is not None:
                get_grade(v)
            return v

    @classmethod
    def output_ports(cls, params: Params) -> dict[str, type[Message]]:
        scenario = _try_load(params.scenario, pipeline_dir())
        ports = {p: t for p, t in PORTS.items() if p in scenario_ports(scenario)}
        return {**ports, **super().output_ports(params)}

    def __init__(self, params: Params, ctx):
        super().__init__(params, ctx)
        from ..simulator import load_scenario, simulate
        self.scenario = load_scenario(_scenario_path(params.scenario, ctx.base_dir))
        self.result = simulate(self.scenario, params.seed, duration_s=params.duration,
                               imu_errors=params.imu_errors, imu_grade=params.imu_grade)
        self._ports = scenario_ports(self.scenario)

    def building(self):
        """The plan the scenario gives the pipeline (not the simulated world)."""
        return self.result.building

    def duration(self) -> tuple[float, float]:
        return 0.0, self.result.t_end

    def messages(self) -> Iterator[tuple[str, Message]]:
        r = self.result
        saturated = sum(int(rec.saturated.sum()) for rec in r.imu.values())
        self.ctx.count("saturated_imu_samples", saturated)
        yield "diagnostics", Diagnostic(
            t=0.0, component=self.ctx.id, level="info", code="simulation",
            text=f"scenario '{self.scenario.name}' seed {r.seed}: {len(r.truth)} agents, "
                 f"{r.t_end:.0f} s, {len(r.breadcrumbs)} breadcrumbs, {len(r.tags)} tags, "
                 f"{saturated} saturated IMU samples")
        yield from r.stream(self.params.block_s, self._ports)


def _scenario_path(name_or_path: str, base_dir: Path) -> Path:
    """A scenario file relative to the pipeline's folder, else a bundled scenario's file.

    Raises ValueError naming both places when neither exists.
    """
    from ..simulator import bundled_scenarios
    from ..simulator.scenario import SCENARIO_DIR
    p = Path(name_or_path).expanduser()
    p = p if p.is_absolute() else base_dir / p
    if p.is_file():
        return p
    bundled = SCENARIO_DIR / f"{name_or_path}.yaml"
    if bundled.is_file():
        return bundled
    raise ValueError(f"scenario '{name_or_path}' not found: no file {p} and no bundled "
                     f"scenario of that name (bundled: {', '.join(bundled_scenarios())})")


def _try_load(name_or_path: str, base_dir: Path):
    """The scenario, for validation; a missing or invalid one raises ValueError with its
    problems, which the pipeline validator shows at the ``scenario`` parameter."""
    from ..simulator import load_scenario
    path = _scenario_path(name_or_path, base_dir)
    try:
        return load_scenario(path)
    except ConfigError as exc:
        raise ValueError("invalid scenario: " + "; ".join(str(p) for p in exc.problems)) from None


PLUGINS = [SimulatorSource]
