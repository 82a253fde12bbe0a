"""What a simulation produced: arrays per agent, messages per stream, static truth."""
from __future__ import annotations

import heapq
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..messages import ImuBlock, Message
from .gait import FootKinematics, StrideTable
from .mount import MountMotion


@dataclass
class ImuRecord:
    """One foot IMU's recording: ``time`` (N,) [s], ``accel`` (N, 3) [m/s^2], ``gyro``
    (N, 3) [rad/s], optional ``mag`` (N, 3) [uT], in the device axes ``frame``;
    ``saturated`` (N,) samples clipped at the range; ``errors``: what was drawn."""

    agent: str
    device: str
    grade: str
    rate_hz: float
    frame: str
    time: np.ndarray
    accel: np.ndarray
    gyro: np.ndarray
    mag: np.ndarray | None
    saturated: np.ndarray
    errors: dict[str, Any] = field(default_factory=dict)

    def blocks(self, block_s: float) -> Iterator[ImuBlock]:
        """The recording cut into ImuBlocks of ``block_s`` seconds."""
        edges = np.floor(self.time / block_s)
        starts = np.concatenate([[0], np.flatnonzero(np.diff(edges)) + 1, [len(self.time)]])
        frame = "FLU" if self.frame == "FLU" else self.frame
        for a, b in zip(starts[:-1], starts[1:]):
            yield ImuBlock(t=float(self.time[b - 1]), agent=self.agent, device=self.device,
                           time=self.time[a:b], accel=self.accel[a:b], gyro=self.gyro[a:b],
                           mag=None if self.mag is None else self.mag[a:b], frame=frame)


@dataclass
class AgentTruth:
    """Ground truth of one firefighter.

    Body (sampled at the truth rate): ``t`` (N,), ``position`` (N, 3) ENU [m] of the
    ground under the body, ``heading`` (N,) [rad] facing direction, ``floor`` (N,),
    ``motion`` (N,) label. Foot (every IMU sample): ``foot`` kinematics, ``strides``;
    ``mount``: the IMU's motion relative to the foot (None: rigid), the IMU itself is at
    ``foot.position + C_b^n mount.u`` (millimetres from the foot point).
    ``checkpoints``: the marked stops (:class:`~.movement.CheckpointRecord`).
    """

    agent: str
    t: np.ndarray
    position: np.ndarray
    heading: np.ndarray
    floor: np.ndarray
    motion: np.ndarray
    foot: FootKinematics | None = None
    mount: MountMotion | None = None
    strides: StrideTable | None = None
    person: dict[str, Any] = field(default_factory=dict)
    checkpoints: list[Any] = field(default_factory=list)

    @property
    def distance_m(self) -> float:
        """Horizontal distance the body travelled [m]."""
        return float(np.sum(np.hypot(*np.diff(self.position[:, :2], axis=0).T)))


@dataclass
class SimulationResult:
    """Everything one run of a scenario produced (see docs/formats/simulation-output.md).

    ``messages`` maps a stream (port) name to its messages in time order: ``uwb``
    (Range), ``rssi`` (RssiReading), ``drops`` (BreadcrumbDrop), ``rfid``
    (TagDetection), ``tags`` (TagDeployment), ``baro`` (RawFrame: barometer lines),
    ``truth`` (GroundTruth). IMU data stay as
    arrays in ``imu`` and become ImuBlocks on demand. ``tags``, ``breadcrumbs`` and
    ``anchors`` hold the true positions of fixed things; ``extra`` per-message truth
    (e.g. the true range of each UWB measurement). ``building`` is the plan the pipeline
    is given, ``world`` the building as it really is (furniture, the plan's errors:
    :mod:`.world`), where the people walked and every truth was computed; the same object
    when the scenario has no ``world``. ``radio``: the path-loss parameters the radio
    links really had (drawn per building and seed when the scenario asks: never given to
    a pipeline).
    """

    scenario: Any
    seed: int
    building: Any
    t_end: float
    imu: dict[str, ImuRecord]
    truth: dict[str, AgentTruth]
    messages: dict[str, list[Message]]
    tags: dict[str, dict[str, Any]] = field(default_factory=dict)
    breadcrumbs: dict[str, dict[str, Any]] = field(default_factory=dict)
    anchors: dict[str, dict[str, Any]] = field(default_factory=dict)
    extra: dict[str, list[dict[str, Any]]] = field(default_factory=dict)
    world: Any = None
    radio: dict[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.world is None:
            self.world = self.building

    @property
    def agents(self) -> list[str]:
        return list(self.truth)

    def stream(self, block_s: float = 0.1, ports: set[str] | None = None
               ) -> Iterator[tuple[str, Message]]:
        """Every message as (port, message), all ports merged in time order."""
        def tagged(port: str, msgs) -> Iterator[tuple[str, Message]]:
            for m in msgs:
                yield port, m

        its = []
        if ports is None or "imu" in ports:
            its += [tagged("imu", rec.blocks(block_s)) for rec in self.imu.values()]
        its += [tagged(port, msgs) for port, msgs in self.messages.items()
                if ports is None or port in ports]
        yield from heapq.merge(*its, key=lambda pm: pm[1].t)
