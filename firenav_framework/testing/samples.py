"""Sample input for the conformance checks: every message type, from one short simulated
run of a bundled scenario, with its building.

The run is the registered ``simulator`` source playing the bundled ``demo`` scenario
(two firefighters searching a 125 m^2 flat with foot IMUs, UWB, RFID, radios; they walk
from t = 10 s). What a sensor or estimator would make of it is derived from the
simulator's ground truth, so the sample depends on no other plugin:

=====================  ===================================================================
stream                 messages
=====================  ===================================================================
``sim.<port>``         the simulator's own (:class:`ImuBlock` in FLU, :class:`Range`,
                       :class:`RssiReading`, :class:`TagDetection`, :class:`TagDeployment`,
                       :class:`GroundTruth`, ...)
``ins.odometry``       :class:`Odometry` every 0.5 s per firefighter: the true motion in
                       a frame equal to the building's
``est.pose``           :class:`PoseEstimate` every 0.5 s per firefighter at the true pose
``est.diagnostics``    a few :class:`Diagnostic` messages
``link.raw``           :class:`RawFrame` of no known protocol on each transport (a CAN
                       id, a MAVLink message, a text line nobody speaks)
=====================  ===================================================================
"""
from __future__ import annotations

import functools
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..contract import Component
from ..geometry import wrap_angle
from ..messages import (Diagnostic, GroundTruth, Message, Odometry, PoseEstimate, RawFrame,
                        Tick)

__all__ = ["SampleWorld", "sample_world", "SAMPLE_SCENARIO"]

#: The bundled scenario, seed and length [s] of the default sample.
SAMPLE_SCENARIO = {"scenario": "demo", "seed": 1, "duration": 30.0}
#: Time between two derived odometry increments or pose estimates [s].
STEP_S = 0.5
#: 1-sigma position [m] and heading [rad] noise declared on derived odometry and poses.
SIGMA_XY, SIGMA_HEADING = 0.05, 0.02


@dataclass(frozen=True)
class SampleWorld:
    """Time-ordered ``(stream, message)`` pairs of every kind, and the building they are in."""

    building: Any
    messages: tuple[tuple[str, Message], ...]

    @property
    def agents(self) -> list[str]:
        """The firefighters of the sample, sorted."""
        return sorted({m.agent for _, m in self.messages if m.agent})

    def input_for(self, cls: type[Component]) -> list[tuple[str, Message]]:
        """The messages whose type ``cls.inputs`` accepts (ticks are the harness's job)."""
        inputs = tuple(t for t in cls.inputs if t is not Tick)
        return [(s, m) for s, m in self.messages
                if inputs and isinstance(m, inputs) and not isinstance(m, Tick)]


@functools.lru_cache(maxsize=2)
def sample_world(scenario: str = SAMPLE_SCENARIO["scenario"], seed: int = SAMPLE_SCENARIO["seed"],
                 duration: float = SAMPLE_SCENARIO["duration"]) -> SampleWorld:
    """The sample of a bundled ``scenario`` run (cached: the checks of every plugin share it).

    Raises RuntimeError when the ``simulator`` source plugin cannot be loaded.
    """
    from ..registry import default_registry
    from .harness import Session

    info = default_registry().get("source", "simulator")
    if info is None:
        raise RuntimeError("the sample input comes from the 'simulator' source plugin, which "
                           "is not installed: " + "; ".join(default_registry().errors))
    sim = Session(info.cls, {"scenario": scenario, "seed": seed, "duration": duration})
    out = [(f"sim.{port}", msg) for port, msg in sim.run().published if port != "diagnostics"]
    truth = [m for _, m in out if isinstance(m, GroundTruth)]
    out += [("ins.odometry", m) for m in odometry_from_truth(truth)]
    out += [("est.pose", m) for m in poses_from_truth(truth)]
    out += [("est.diagnostics", m) for m in _diagnostics(truth)]
    out += [("link.raw", m) for m in _foreign_frames(duration)]
    out.sort(key=lambda item: float(item[1].t))
    return SampleWorld(building=sim.component.building(), messages=tuple(out))


def _every(truth: Iterable[GroundTruth], step_s: float) -> dict[str, list[GroundTruth]]:
    """Per agent, the truth samples at least ``step_s`` apart."""
    picked: dict[str, list[GroundTruth]] = {}
    for m in truth:
        rows = picked.setdefault(m.agent, [])
        if not rows or m.t - rows[-1].t >= step_s - 1e-9:
            rows.append(m)
    return picked


def odometry_from_truth(truth: Iterable[GroundTruth], step_s: float = STEP_S) -> list[Odometry]:
    """Odometry increments every ``step_s`` [s] per agent: the true displacement and heading
    change, in an odometry frame that coincides with the building frame."""
    cov = np.diag([SIGMA_XY ** 2, SIGMA_XY ** 2, SIGMA_XY ** 2, SIGMA_HEADING ** 2])
    out = []
    for agent, rows in _every(truth, step_s).items():
        for a, b in zip(rows, rows[1:]):
            delta = np.asarray(b.position, float) - np.asarray(a.position, float)
            moving = float(np.hypot(delta[0], delta[1])) > 0.05
            out.append(Odometry(t=float(b.t), agent=agent, device=f"{agent}/imu",
                                t_start=float(a.t), delta=delta,
                                dheading=wrap_angle(b.heading - a.heading), cov=cov,
                                position=np.asarray(b.position, float), heading=float(b.heading),
                                motion="walk" if moving else "still"))
    return out


def poses_from_truth(truth: Iterable[GroundTruth], step_s: float = STEP_S) -> list[PoseEstimate]:
    """Pose estimates every ``step_s`` [s] per agent at the true pose, in the building frame."""
    cov = np.diag([SIGMA_XY ** 2, SIGMA_XY ** 2, SIGMA_XY ** 2, SIGMA_HEADING ** 2])
    return [PoseEstimate(t=float(m.t), agent=agent, device=f"{agent}/estimate",
                         position=np.asarray(m.position, float), heading=float(m.heading),
                         cov=cov, floor=m.floor)
            for agent, rows in _every(truth, step_s).items() for m in rows]


def _diagnostics(truth: list[GroundTruth]) -> list[Diagnostic]:
    agents = sorted({m.agent for m in truth})
    out = [Diagnostic(t=1.0, component="est", level="info", code="started", text="estimator up")]
    for k, agent in enumerate(agents):
        out.append(Diagnostic(t=12.0 + k, agent=agent, component="est", level="warning",
                              code="untrusted", text=f"{agent}: spread above 2 m"))
        out.append(Diagnostic(t=20.0 + k, agent=agent, component="est", level="warning",
                              code="untrusted", text=f"{agent}: spread back below 2 m",
                              active=False))
    return out


def _foreign_frames(duration: float) -> list[RawFrame]:
    """Frames of no protocol firenav knows, on every transport, spread over the run."""
    frames = [("can", 0x7AB, bytes(range(8))), ("mavlink", 30001, b"\xfd\x09\x00\x00\x07"),
              ("serial", "", b"ZZTOP,1,2,3*5A"), ("udp", "", b"not a firenav line")]
    return [RawFrame(t=duration * (k + 1) / (len(frames) + 1), device=f"link{k}",
                     transport=transport, channel=channel, data=data)
            for k, (transport, channel, data) in enumerate(frames)]
