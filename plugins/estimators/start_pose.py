"""How the built-in estimators read their ``start`` parameter.

Every estimator's start is the one :class:`~firenav_framework.contract.params.StartPose`
model (``start: {mode: entrance}``, ``start: {mode: pose, position: [x, y, z], heading:
90 deg}``). Estimators differ only in their defaults (a particle filter starts with a
tighter spread than the RFID EKF) and in the modes they can honour, which
:func:`start_pose_type` declares. :func:`entrance_of` is the building-entrance lookup
of mode ``entrance``.
"""
from __future__ import annotations

from collections.abc import Mapping
from typing import Annotated, Any

import numpy as np
from pydantic import AfterValidator, BeforeValidator

from firenav_framework import StartPose
from firenav_framework.building.model import Entrance

__all__ = ["start_pose_type", "missing_headings", "entrance_of", "entrance_start"]


def start_pose_type(default: StartPose, modes: tuple[str, ...], *,
                    needs_heading: bool = True) -> Any:
    """The type of an estimator's ``start`` parameter.

    Keys a pipeline writes override ``default`` key by key, so ``start: {mode: pose,
    position: [1, 2, 0], heading: 0}`` keeps this estimator's default uncertainties. The
    ``mode`` must be one of ``modes``; a position, heading or per-agent pose given with
    another mode than ``pose`` is refused rather than silently ignored. Mode ``pose``
    needs a position (or ``agents``) and, with ``needs_heading``, every pose's heading.
    """
    base = default.model_dump(exclude_unset=True)

    def fill(value: Any) -> Any:
        return {**base, **value} if isinstance(value, Mapping) else value

    def check(start: StartPose) -> StartPose:
        if start.mode not in modes:
            raise ValueError(f"start mode '{start.mode}' is not available here; use one of: "
                             f"{', '.join(modes)}")
        if start.mode != "pose":
            given = [k for k in ("position", "heading") if getattr(start, k) is not None]
            given += ["agents"] if start.agents else []
            if given:
                raise ValueError(f"start {', '.join(given)} given, but they are read only with "
                                 f"mode 'pose' (mode is '{start.mode}')")
        elif start.position is None and not start.agents:
            raise ValueError("start mode 'pose' needs a position (or agents with their poses)")
        elif needs_heading and missing_headings(start):
            raise ValueError(f"start mode 'pose' needs a heading for "
                             f"{', '.join(missing_headings(start))}")
        return start

    return Annotated[type(default), BeforeValidator(fill), AfterValidator(check)]


def missing_headings(start: StartPose) -> list[str]:
    """Who has a start position but no heading in mode ``pose``: ``"position"`` for the
    common pose, else the agents' names."""
    missing = ["position"] if start.position is not None and start.heading is None else []
    return missing + [a for a, pose in start.agents.items() if pose.heading is None]


def entrance_of(building: Any, entrance: str | None) -> Entrance:
    """The building's entrance ``entrance`` (None: its first), or a ValueError that says
    what there is instead."""
    if not building.entrances:
        raise ValueError(f"building {building.name!r} has no entrance: give the start pose "
                         "(start: {mode: pose, position: [x, y, z], heading: ...})")
    if entrance is None:
        return building.entrances[0]
    for e in building.entrances:
        if e.id == entrance:
            return e
    raise ValueError(f"no entrance {entrance!r}; the building has "
                     f"{', '.join(e.id for e in building.entrances)}")


def entrance_start(building: Any, entrance: str | None) -> tuple[np.ndarray, Entrance]:
    """Start position (3,) [m] at the entrance ``entrance`` (None: the first), on its floor's
    level, and the entrance itself (inward ``heading`` [rad], ``floor``)."""
    e = entrance_of(building, entrance)
    return np.array([e.position[0], e.position[1], building.floors[e.floor].z], float), e
