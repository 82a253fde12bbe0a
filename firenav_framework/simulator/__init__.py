"""The scenario simulator: firefighters, their movements and their sensors.

``load_scenario(path_or_name)`` reads a scenario YAML; ``simulate(scenario, seed)``
runs it and returns a :class:`SimulationResult` (IMU arrays per agent, messages per
stream, ground truth); ``bundled_scenarios()`` lists the reference scenarios. The
``simulator`` source plugin (:mod:`firenav_framework.sources.simulator`) plays a run
into a pipeline and ``firenav simulate`` writes one to files.
"""
from .engine import simulate
from .imu_grades import GRADES, ImuGrade, get_grade
from .result import AgentTruth, ImuRecord, SimulationResult
from .scenario import Scenario, bundled_scenarios, load_scenario, load_scenario_text

__all__ = ["simulate", "load_scenario", "load_scenario_text", "bundled_scenarios", "Scenario",
           "SimulationResult", "AgentTruth", "ImuRecord", "GRADES", "ImuGrade", "get_grade"]
