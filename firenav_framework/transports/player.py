"""Plays sensor data onto live links as the real devices would (``firenav play``, tests, benchmarks).

Frames are made by registered IMU codecs (:mod:`firenav_framework.codecs`), named per
link: by default ``can_imu`` (the reference foot IMU's DBC) on CAN and ``mavlink_imu``
(HIGHRES_IMU) on MAVLink; a vendor's codec is one name away. Each IMU device is
assigned a link and a codec address by :func:`team_layout`, the layout of
``pipelines/field-live.yaml``: the firefighter at position N (1-based: the order of
the scenario's agent list, or of first appearance in a recording) is

* on MAVLink: ``sys<N>/comp1/imu<foot>`` (system id N, component 1, IMU index 0 for
  the left foot and 1 for the right);
* on CAN: the CAN codec's address number ``2 (N - 1) + foot`` (left 0, right 1) in the
  order of :meth:`~firenav_framework.codecs.Codec.addresses`: the reference DBC has
  nodes 0-7 (ids ``0x100 + 0x10 * node``), so firefighters 1-4.

MAVLink's body frame is FRD, so blocks in FLU axes (the simulator's default) are sent
as FRD (y and z negated, exactly); other device axes are sent as they are, as are all
CAN frames (the reference device sends its case axes). Blocks are sent when the wall
clock reaches their last sample time (``speed`` times faster), so the field kit
receives them at a device's pace. The other sensors (UWB, RFID, barometer, breadcrumb
radio) are encoded by :class:`~.radio_frames.RadioEncoder` and sent on the CAN bus or
the text-line link (``lines``: anything with ``write(bytes)``, one line per frame) at
their message time. The player only assigns and moves frames;
:meth:`DevicePlayer.encode` and :meth:`DevicePlayer.transmit` are separate so tests
can tamper with frames between.
"""
from __future__ import annotations

import dataclasses
import threading
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import can
import numpy as np

from ..codecs import Codec, EncodedFrame, get_codec
from ..messages import ImuBlock, Message
from .radio_frames import LINE_LINK, RadioEncoder

#: The codec of each link unless the player is told otherwise.
DEFAULT_CODECS = {"can": "can_imu", "mavlink": "mavlink_imu"}
_FLU_TO_FRD = np.array([1.0, -1.0, -1.0])
_LINK_NAMES = {"can": "CAN", "mavlink": "MAVLink", LINE_LINK: "lines"}
#: What ends each frame on the line link.
LINE_END = b"\n"


@dataclass(frozen=True)
class Assignment:
    """Where one device's samples go: a link (``"can"``, ``"mavlink"``) and the codec
    address to send as (``node1``, ``sys3/comp1/imu0``); ``channels`` the ids it uses."""

    link: str
    address: str
    channels: tuple[int | str, ...] = field(default=(), compare=False)

    def __str__(self) -> str:
        return f"{_LINK_NAMES.get(self.link, self.link)} {self.address}{_channel_text(self)}"


def _channel_text(a: Assignment) -> str:
    """`` (ids 0x110-0x112)`` for a run of CAN ids, else the channels listed."""
    ch = a.channels
    if not ch:
        return ""
    name = "ids" if a.link == "can" else "msgids"
    if all(isinstance(c, int) for c in ch):
        if len(ch) > 1 and sorted(ch) == list(range(min(ch), max(ch) + 1)):
            return f" ({name} 0x{min(ch):03X}-0x{max(ch):03X})"
        return f" ({name} {', '.join(f'0x{c:03X}' if a.link == 'can' else str(c) for c in ch)})"
    return f" ({name} {', '.join(map(str, ch))})"


def foot_index(device: str, known: dict[str, str] | None = None) -> int | None:
    """0 for a left-foot device, 1 for a right one, None when neither is known.

    ``known`` maps devices to ``"left"``/``"right"`` (a scenario says which foot wears
    each IMU); otherwise a device name ending in ``left``/``right`` decides.
    """
    side = (known or {}).get(device) or device.rsplit("/", 1)[-1].lower()
    return {"left": 0, "right": 1}.get(side)


def team_layout(position: int, foot: int, over_mavlink: bool,
                can_addresses: Sequence[str]) -> Assignment:
    """The assignment of the ``foot`` (0 left, 1 right) IMU of the firefighter at
    1-based ``position`` (see the module docstring); ``can_addresses`` are the CAN
    codec's device addresses, in order."""
    if position < 1 or foot not in (0, 1):
        raise ValueError(f"position must be >= 1 and foot 0 or 1, got {position}, {foot}")
    if over_mavlink:
        if position > 254:
            raise ValueError(f"MAVLink has system ids 1-254; firefighter {position} has none")
        return Assignment("mavlink", f"sys{position}/comp1/imu{foot}")
    node = 2 * (position - 1) + foot
    if node >= len(can_addresses):
        raise ValueError(f"the CAN codec has {len(can_addresses)} device addresses "
                         f"(firefighters 1-{len(can_addresses) // 2}); firefighter "
                         f"{position} needs a {node + 1}th: send it over MAVLink")
    return Assignment("can", can_addresses[node])


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

    def assign(self, agent: str, device: str, can_addresses: Sequence[str]) -> Assignment:
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
        return team_layout(self.order.index(agent) + 1, foot, over_mavlink, can_addresses)


@dataclass
class DevicePlayer:
    """Sends ImuBlocks of assigned devices onto a CAN bus and/or a MAVLink connection,
    and the other sensors' messages onto the CAN bus and the line link.

    ``mavlink`` and ``lines`` are anything with ``write(bytes)`` (a pymavlink
    connection, a serial port, a socket wrapper). ``codecs`` names the IMU codec of each
    link (:data:`DEFAULT_CODECS` for the links it leaves out). ``assignments`` maps
    device ids to :class:`Assignment`; blocks of other devices are not sent. ``radio``
    encodes the other sensors (None: only IMUs are sent); a message whose link is not
    there is counted in ``skipped`` (per link), not sent.
    """

    can_bus: can.BusABC | None = None
    mavlink: Any = None
    lines: Any = None
    assignments: dict[str, Assignment] = field(default_factory=dict)
    speed: float = 1.0
    codecs: Mapping[str, str] = field(default_factory=dict)
    radio: RadioEncoder | None = None
    sent: dict[str, int] = field(default_factory=lambda: {"can": 0, "mavlink": 0, LINE_LINK: 0})
    skipped: dict[str, int] = field(default_factory=dict)
    _t0: tuple[float, float] | None = None
    _encoders: dict[str, Codec] = field(default_factory=dict)

    def codec(self, link: str) -> Codec:
        """The encoder of ``link`` (made on first use; it keeps the sequence counters)."""
        codec = self._encoders.get(link)
        if codec is None:
            name = self.codecs.get(link) or DEFAULT_CODECS[link]
            codec = self._encoders[link] = get_codec(name)()
        return codec

    def assignment(self, block: ImuBlock, roster: Roster | None) -> Assignment | None:
        """The assignment of ``block``'s device; a new device is assigned by ``roster``
        (None: only devices already in :attr:`assignments` are sent)."""
        a = self.assignments.get(block.device)
        if a is None and roster is not None:
            a = roster.assign(block.agent, block.device, self.codec("can").addresses() or ())
            channels = self.codec(a.link).channels(a.address) or ()
            a = self.assignments[block.device] = dataclasses.replace(a, channels=tuple(channels))
        return a

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

    def encode(self, block: ImuBlock) -> tuple[str, list[EncodedFrame]] | None:
        """``(link, frames)`` of one block of an assigned device (None: not assigned);
        sample counters continue across blocks per device."""
        a = self.assignments.get(block.device)
        if a is None:
            return None
        if a.link == "mavlink" and block.frame == "FLU":
            block = dataclasses.replace(block, accel=block.accel * _FLU_TO_FRD,
                                        gyro=block.gyro * _FLU_TO_FRD, frame="FRD")
        return a.link, self.codec(a.link).encode(block, address=a.address)

    def transmit(self, link: str, frames: Iterable[EncodedFrame]) -> int:
        """Put encoded frames on ``link`` ("can", "mavlink" or "lines"); returns how many."""
        n = 0
        if link == "can":
            for f in frames:
                self.can_bus.send(can.Message(arbitration_id=f.channel, data=f.data,
                                              is_extended_id=f.channel > 0x7FF))
                n += 1
        else:
            out = self.mavlink if link == "mavlink" else self.lines
            end = LINE_END if link == LINE_LINK else b""
            for f in frames:
                out.write(f.data + end)
                n += 1
        self.sent[link] += n
        return n

    def play(self, messages: Iterable[Message], roster: Roster | None = None,
             stop: threading.Event | None = None,
             on_assign: Callable[[str, Assignment], None] | None = None) -> None:
        """Pace and send ``messages`` (time order): ImuBlocks of devices not yet assigned
        are assigned by ``roster`` (and reported to ``on_assign(device, assignment)``),
        other messages go to :attr:`radio`. Ends early when ``stop`` is set."""
        for msg in messages:
            if stop is not None and stop.is_set():
                return
            if not isinstance(msg, ImuBlock):
                encoded = None if self.radio is None else self.radio.encode(msg)
                if encoded is not None:
                    self.pace(msg.t)
                    self.send_encoded(*encoded)
                continue
            if msg.device not in self.assignments and roster is not None:
                a = self.assignment(msg, roster)
                if on_assign is not None:
                    on_assign(msg.device, a)
            self.pace(msg.t)
            self.send(msg)

    def send(self, block: ImuBlock) -> int:
        """Encode and send one block; returns the frames sent (0: device not assigned)."""
        encoded = self.encode(block)
        return 0 if encoded is None else self.transmit(*encoded)

    def send_encoded(self, link: str, frames: list[EncodedFrame]) -> int:
        """:meth:`transmit` when ``link`` is there; else count the frames in
        :attr:`skipped` and send nothing. Returns the frames sent."""
        if {"can": self.can_bus, "mavlink": self.mavlink, LINE_LINK: self.lines}[link] is None:
            self.skipped[link] = self.skipped.get(link, 0) + len(frames)
            return 0
        return self.transmit(link, frames)
