"""Plugin parameters: the pydantic base, ``param()`` with units, SI angle types and the
one start-pose model every estimator uses.

A plugin's ``Params`` model is at once its YAML schema, its ``firenav plugins show``
table and its documentation. Parameters are SI: metres, seconds, radians. Angles may be
written in a pipeline with a unit (``heading: 90 deg``, ``yaw_rate_sigma: 0.2 deg/s``);
they are stored in radians (radians per second), which is what the plugin reads.
Related parameters form nested models (``detector: {window: 0.025}``).

No parameter may be NaN (``.nan`` in YAML is refused, located, for every plugin);
positions (:data:`Vec3`) and angles must also be finite.
"""
from __future__ import annotations

import math
import re
from typing import Annotated, Any, Literal

from pydantic import AllowInfNan, BeforeValidator, ConfigDict, Field, field_validator

from ..field_docs import DescribedModel

__all__ = ["Params", "param", "Angle", "AngularRate", "Vec3", "AgentPose", "StartPose",
           "parse_angle"]


class Params(DescribedModel):
    """Base for plugin parameter models: unknown keys are errors, values are checked,
    no value is NaN, and each parameter's description is its docstring."""

    model_config = ConfigDict(extra="forbid", frozen=True, validate_default=True)

    @field_validator("*", mode="after")
    @classmethod
    def _no_nan(cls, value: Any) -> Any:
        if _has_nan(value):
            raise ValueError("must be a number, not NaN")
        return value


def _has_nan(value: Any) -> bool:
    if isinstance(value, float):
        return math.isnan(value)
    if isinstance(value, (tuple, list)):
        return any(_has_nan(v) for v in value)
    if isinstance(value, dict):
        return any(_has_nan(v) for v in value.values())
    return False


def param(default: Any = ..., *, unit: str | None = None, description: str | None = None,
          **constraints: Any) -> Any:
    """A pydantic ``Field`` that also records the physical unit of a parameter.

    The description is the attribute's docstring (the string right below it), or
    ``description=`` where there is none:

    >>> class P(Params):
    ...     read_range: float = param(5.0, unit="m", gt=0)
    ...     '''how far a tag is read'''
    """
    extra = {"unit": unit} if unit else None
    return Field(default, description=description, json_schema_extra=extra, **constraints)


_ANGLE = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*([a-z/]*)\s*$")
_ANGLE_UNITS = {"": 1.0, "rad": 1.0, "deg": math.pi / 180.0}
_RATE_UNITS = {"": 1.0, "rad/s": 1.0, "deg/s": math.pi / 180.0, "deg/min": math.pi / 10800.0,
               "deg/h": math.pi / 648000.0}


def parse_angle(value: Any, units: dict[str, float] = _ANGLE_UNITS) -> Any:
    """A number (already SI) or a string ``"<number> <unit>"`` -> SI float.

    Other values are returned unchanged for pydantic to reject with its own message.
    """
    if isinstance(value, str):
        m = _ANGLE.match(value)
        if m is None or m.group(2) not in units:
            raise ValueError(f"expected a number with a unit of {', '.join(u for u in units if u)}"
                             f", got {value!r}")
        return float(m.group(1)) * units[m.group(2)]
    return value


#: An angle [rad], finite; YAML may say ``90 deg`` or ``1.57 rad``.
Angle = Annotated[float, BeforeValidator(parse_angle), AllowInfNan(False)]
#: An angular rate [rad/s], finite; YAML may say ``0.2 deg/s``, ``15 deg/min`` or ``8 deg/h``.
AngularRate = Annotated[float, BeforeValidator(lambda v: parse_angle(v, _RATE_UNITS)),
                        AllowInfNan(False)]
_Finite = Annotated[float, AllowInfNan(False)]
#: A position or vector (x, y, z) [m], finite, building-frame ENU unless said otherwise.
Vec3 = tuple[_Finite, _Finite, _Finite]


class AgentPose(Params):
    """A known pose of one firefighter: position (x, y, z) [m] and heading [rad], ENU."""

    position: Vec3 = param(unit="m")
    """position (x, y, z), building frame"""
    heading: Angle | None = param(None, unit="rad")
    """walking direction, counter-clockwise from east (None: unknown)"""


class StartPose(Params):
    """Where each firefighter starts, in the building frame.

    ``mode``:

    * ``entrance``: the building entrance ``entrance`` (default: its first), at its
      position with its inward heading;
    * ``pose``: ``position`` / ``heading`` (and ``agents`` per firefighter);
    * ``truth``: the pose of a GroundTruth input stream when the estimator starts (a
      surveyed start; for evaluation against the simulator);
    * ``unknown``: no start is known: an estimator that can localise globally does so,
      the others stay in their own odometry frame.

    ``sigma_position`` [m] and ``sigma_heading`` [rad] are the 1-sigma uncertainty of
    the start given by ``entrance``, ``pose`` or ``truth``.
    """

    mode: Literal["entrance", "pose", "truth", "unknown"] = param("entrance")
    """where the start comes from: entrance | pose | truth | unknown"""
    entrance: str | None = param(None)
    """entrance id for mode 'entrance' (default: the building's first entrance)"""
    position: Vec3 | None = param(None, unit="m")
    """mode 'pose': start position (x, y, z), building frame"""
    heading: Angle | None = param(None, unit="rad")
    """mode 'pose': start walking direction, counter-clockwise from east"""
    floor: int | None = param(None, ge=0)
    """start floor index (default: from the position's height, else 0)"""
    agents: dict[str, AgentPose] = param({})
    """mode 'pose': per-firefighter poses overriding position/heading"""
    sigma_position: float = param(0.3, unit="m", ge=0)
    """start position uncertainty (1 sigma, per horizontal axis)"""
    sigma_heading: Angle = param(0.05, unit="rad", ge=0)
    """start heading uncertainty (1 sigma)"""

    def pose_of(self, agent: str) -> tuple[Vec3 | None, float | None]:
        """(position, heading) given for ``agent`` in mode ``pose`` (None where not given)."""
        if agent in self.agents:
            a = self.agents[agent]
            return a.position, a.heading
        return self.position, self.heading
