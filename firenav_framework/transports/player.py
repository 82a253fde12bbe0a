"""Plays IMU data onto live links as the real devices would (``firenav play``, tests, benchmarks).

Each IMU device is assigned a link by :func:`team_layout`, the layout of
``pipelines/field-live.yaml``: the firefighter at position N (1-based: the order of
the scenario's agent list, or of first appearance in a recording) is

* on MAVLink: system id N, component 1, HIGHRES_IMU ``id`` 0 for the left foot and 1
  for the right (packets from ``firenav_plugins.sensors.imu_mavlink.encode_mavlink_imu``);
* on CAN: reference-DBC node ``2 (N - 1) + foot`` (left 0, right 1), ids
  ``0x100 + 0x10 * node`` (ACCEL, GYRO, TIME frames per sample from
  ``firenav_plugins.sensors.imu_can.encode_can_imu``); the DBC has nodes 0-7, so
  firefighters 1-4.

MAVLink's body frame is FRD, so blocks in FLU axes (the simulator's default) are sent
as FRD (y and z negated, exactly); other device axes are sent as they are, as are all
CAN frames (the reference device sends its case axes). Blocks are sent when the wall
clock reaches their last sample time (``speed`` times faster), so the field kit
receives them at a device's pace. Encoding is the sensor plugins' job; the player
only assigns and moves frames, and :meth:`DevicePlayer.encode` /
:meth:`DevicePlayer.transmit` are separate so tests can tamper with frames between.
"""
from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

import can
import numpy as np

from ..messages import ImuBlock

#: CAN nodes of the reference DBC (plugins/sensors/dbc/firenav_imu.dbc).
CAN_NODES = 8
_FLU_TO_FRD = np.array([1.0, -1.0, -1.0])


@dataclass(frozen=True)
class Assignment:
    """Where one device's samples go: ``("can", node)`` or ``("mavlink", sysid, imu_id)``."""

    link: str
    node: int = 0
    sysid: int = 1
    imu_id: int = 0

    def __str__(self) -> str:
        return (f"CAN node {self.node} (ids 0x{0x100 + 0x10 * self.node:03X}-"
                f"0x{0x102 + 0x10 * self.node:03X})" if self.link == "can"
                else f"MAVLink sys{self.sysid}/comp1 HIGHRES_IMU id {self.imu_id}")


def foot_index(device: str, known: dict[str, str] | None = None) -> int | None:
    """0 for a left-foot device, 1 for a right one, None when neither is known.

    ``known`` maps devices to ``"left"``/``"right"`` (a scenario says which foot wears
    each IMU); otherwise a device name ending in ``left``/``right`` decides.
    """
    side = (known or {}).get(device) or device.rsplit("/", 1)[-1].lower()
    return {"left": 0, "right": 1}.get(side)


def team_layout(position: int, foot: int, over_mavlink: bool) -> Assignment:
    """The assignment of the ``foot`` (0 left, 1 right) IMU of the firefighter at
    1-based ``position`` (see the module docstring)."""
    if position < 1 or foot not in (0, 1):
        raise ValueError(f"position must be >= 1 and foot 0 or 1, got {position}, {foot}")
    if over_mavlink:
        if position > 254:
            raise ValueError(f"MAVLink has system ids 1-254; firefighter {position} has none")
        return Assignment("mavlink", sysid=position, imu_id=foot)
    node = 2 * (position - 1) + foot
    if node >= CAN_NODES:
        raise ValueError(f"the reference CAN layout has nodes 0-{CAN_NODES - 1} (firefighters "
                         f"1-{CAN_NODES // 2}); firefighter {position} needs node {node}: "
                         "send it over MAVLink")
    return Assignment("can", node=node)


@dataclass
class Roster:
    """Who is played where: positions of the firefighters and feet of their devices.

    ``order`` lists agents by position (a scenario's agent list; agents not in it are
    appended in order of first appearance). ``feet`` maps devices to ``"left"`` /
    ``"right"`` where known; a device whose foot is unknown takes the first free one
    of its agent. ``mavlink_agents`` are sent over MAVLink, the others over CAN
    (None: everyone over MAVLink).
    """

    order: list[str] = field(default_factory=list)
    feet: dict[str, str] = field(default_factory=dict)
    mavlink_agents: set[str] | None = None
    _taken: dict[str, set[int]] = field(default_factory=dict)

    @classmethod
    def of_scenario(cls, scenario: Any, mavlink_agents: set[str] | None = None) -> "Roster":
        """The scenario's agents in file order (those without an IMU keep their place),
        each IMU on the foot the scenario names."""
        agents = scenario.model.agents
        return cls(order=[a.id for a in agents],
                   feet={f"{a.id}/imu": a.person.foot for a in agents if a.sensors.imu},
                   mavlink_agents=mavlink_agents)

    def assign(self, agent: str, device: str) -> Assignment:
        """The assignment of a device seen for the first time (see :func:`team_layout`)."""
        if agent not in self.order:
            self.order.append(agent)
        taken = self._taken.setdefault(agent, set())
        foot = foot_index(device, self.feet)
        if foot is None or foot in taken:
            free = [f for f in (0, 1) if f not in taken]
            if not free:
                raise ValueError(f"{device}: firefighter {agent} already has a left and a "
                                 "right foot IMU; the layout has no place for a third")
            foot = free[0]
        taken.add(foot)
        over_mavlink = self.mavlink_agents is None or agent in self.mavlink_agents
        return team_layout(self.order.index(agent) + 1, foot, over_mavlink)


@dataclass
class DevicePlayer:
    """Sends ImuBlocks of assigned devices onto a CAN bus and/or a MAVLink connection.

    ``mavlink`` is anything with ``write(bytes)`` (a pymavlink connection, a socket
    wrapper). ``assignments`` maps device ids to :class:`Assignment`; blocks of other
    devices are not sent.
    """

    can_bus: can.BusABC | None = None
    mavlink: Any = None
    assignments: dict[str, Assignment] = field(default_factory=dict)
    speed: float = 1.0
    sent: dict[str, int] = field(default_factory=lambda: {"can": 0, "mavlink": 0})
    _t0: tuple[float, float] | None = None
    _seq: dict[str, int] = field(default_factory=dict)

    def pace(self, t: float) -> None:
        """Wait until the wall clock reaches data time ``t`` [s] (scaled by ``speed``;
        ``speed`` <= 0: no waiting)."""
        if self.speed <= 0:
            return
        if self._t0 is None:
            self._t0 = (time.monotonic(), t)
        delay = self._t0[0] + (t - self._t0[1]) / self.speed - time.monotonic()
        if delay > 0:
            time.sleep(delay)

    def encode(self, block: ImuBlock) -> tuple[str, list] | None:
        """``(link, frames)`` of one block of an assigned device (None: not assigned).

        Frames are :class:`~firenav_plugins.sensors.imu_frames.EncodedFrame`; sample
        counters continue across blocks per device.
        """
        a = self.assignments.get(block.device)
        if a is None:
            return None
        seq = self._seq.get(block.device, 0)
        self._seq[block.device] = seq + len(block)
        t = np.asarray(block.time, float)
        if a.link == "can":
            from firenav_plugins.sensors.imu_can import encode_can_imu
            return "can", encode_can_imu(t, block.accel, block.gyro, node=a.node,
                                         seq_start=seq)
        from firenav_plugins.sensors.imu_mavlink import encode_mavlink_imu
        accel, gyro = block.accel, block.gyro
        if block.frame == "FLU":
            accel, gyro = accel * _FLU_TO_FRD, gyro * _FLU_TO_FRD
        return "mavlink", encode_mavlink_imu(t, accel, gyro, sysid=a.sysid, imu_id=a.imu_id,
                                             seq_start=seq)

    def transmit(self, link: str, frames: Iterable) -> int:
        """Put encoded frames on ``link`` ("can" or "mavlink"); returns how many."""
        n = 0
        if link == "can":
            for f in frames:
                self.can_bus.send(can.Message(arbitration_id=f.channel, data=f.data,
                                              is_extended_id=False))
                n += 1
        else:
            for f in frames:
                self.mavlink.write(f.data)
                n += 1
        self.sent[link] += n
        return n

    def play(self, blocks: Iterable[ImuBlock], roster: Roster | None = None,
             stop: threading.Event | None = None,
             on_assign: Callable[[str, Assignment], None] | None = None) -> None:
        """Pace and send ``blocks`` (time order); devices not yet assigned are assigned
        by ``roster`` (and reported to ``on_assign(device, assignment)``). Ends early
        when ``stop`` is set."""
        for block in blocks:
            if stop is not None and stop.is_set():
                return
            if block.device not in self.assignments and roster is not None:
                a = self.assignments[block.device] = roster.assign(block.agent, block.device)
                if on_assign is not None:
                    on_assign(block.device, a)
            self.pace(block.t)
            self.send(block)

    def send(self, block: ImuBlock) -> int:
        """Encode and send one block; returns the frames sent (0: device not assigned)."""
        encoded = self.encode(block)
        return 0 if encoded is None else self.transmit(*encoded)
