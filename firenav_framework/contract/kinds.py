"""The five plugin kinds and their base classes."""
from __future__ import annotations

from .component import Component
from .constraint import Constraint
from .estimator import Estimator
from .sensor import Sensor
from .sink import Sink
from .source import Source

__all__ = ["KINDS", "KIND_BASES"]

KINDS = ("source", "sensor", "estimator", "constraint", "sink")

KIND_BASES: dict[str, type[Component]] = {
    "source": Source, "sensor": Sensor, "estimator": Estimator,
    "constraint": Constraint, "sink": Sink,
}
