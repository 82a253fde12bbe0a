"""``breadcrumb_lines``: the breadcrumb radio network's text lines (``docs/formats/breadcrumb-radio.md``)::

    RSSI,<receiver>,<transmitter>,<rssi_dbm>[*HH]    a packet heard, its signal strength
    DROP,<dispenser>,<node_id>[*HH]                  the dispenser dropped this breadcrumb

Radio names: a fixed node (a breadcrumb ``bc3``, the base station ``base``) by its node
id; a firefighter's worn radio as ``<agent>/radio`` and a dispenser as
``<agent>/dispenser`` (the ``<agent>/<device>`` convention of the RFID readers and
barometers). The worn radio's node id in the network is the firefighter's id.
``rssi_dbm`` is a decimal [dBm]; ``*HH`` is optional: the XOR of the bytes before ``*``
in hex, as NMEA (:mod:`.checked_lines`). The event's time is the frame's (the receive
clock). :func:`radio_message` and :func:`radio_event` convert between the events and
the framework's :class:`~firenav_framework.messages.RssiReading` /
:class:`~firenav_framework.messages.BreadcrumbDrop` messages.
"""
from __future__ import annotations

import math
from collections.abc import Collection
from typing import Literal, NamedTuple

from ..messages import BreadcrumbDrop, RssiReading
from .base import FrameError
from .checked_lines import NAME, CheckedLinesCodec

__all__ = ["RadioEvent", "BreadcrumbLinesCodec", "radio_message", "radio_event",
           "WORN_RADIO"]

#: The device name of a firefighter's worn radio: ``<agent>/radio``.
WORN_RADIO = "radio"


class RadioEvent(NamedTuple):
    """One breadcrumb-radio line.

    ``kind`` "RSSI": ``device`` the receiving radio, ``node`` the transmitting one (each
    a node id or ``<agent>/radio``), ``rssi_dbm`` [dBm]. ``kind`` "DROP": ``device`` the
    dispenser (``<agent>/dispenser``), ``node`` the dropped breadcrumb's node id.
    ``t`` [s] the frame's time.
    """

    t: float
    kind: Literal["RSSI", "DROP"]
    device: str
    node: str
    rssi_dbm: float | None = None


def _agent(name: str) -> str:
    """The firefighter of a device name ``<agent>/<device>`` ('' for a fixed node)."""
    return name.split("/", 1)[0] if "/" in name else ""


def _node(name: str) -> str:
    """The network node id of a radio name (a worn radio's is its firefighter's id)."""
    return _agent(name) or name


def _radio_name(node: str, worn: bool) -> str:
    return f"{node}/{WORN_RADIO}" if worn else node


def radio_message(e: RadioEvent) -> RssiReading | BreadcrumbDrop:
    """The framework message of an event.

    A reading's ``agent`` is the receiving firefighter, else the transmitting one (a
    fixed node hearing a worn radio), else ''; its ``device`` the receiving radio.
    """
    if e.kind == "DROP":
        return BreadcrumbDrop(t=e.t, agent=_agent(e.device), device=e.device, node_id=e.node)
    return RssiReading(t=e.t, agent=_agent(e.device) or _agent(e.node), device=e.device,
                       tx=_node(e.node), rx=_node(e.device), rssi_dbm=e.rssi_dbm)


def radio_event(msg: RssiReading | BreadcrumbDrop, firefighters: Collection[str]) -> RadioEvent:
    """The event that carries ``msg`` (the inverse of :func:`radio_message`); nodes in
    ``firefighters`` (the team's ids) are sent as their worn radios."""
    if isinstance(msg, BreadcrumbDrop):
        return RadioEvent(msg.t, "DROP", msg.device or f"{msg.agent}/dispenser", msg.node_id)
    return RadioEvent(msg.t, "RSSI", _radio_name(msg.rx, msg.rx in firefighters),
                      _radio_name(msg.tx, msg.tx in firefighters), msg.rssi_dbm)


class BreadcrumbLinesCodec(CheckedLinesCodec):
    """Breadcrumb radio lines: RSSI readings and DROP events, with an optional *HH checksum.

    Other lines on the link are not ours (None); a broken RSSI or DROP line raises
    :class:`FrameError` (``checksum_errors`` for a wrong checksum, else ``bad_frames``).
    """

    name = "breadcrumb_lines"
    record = RadioEvent
    field_counts = {"RSSI": (4,), "DROP": (3,)}

    def parse(self, t: float, parts: list[str], text: str) -> RadioEvent:
        kind, device, node = parts[0], parts[1], parts[2]
        if not (NAME.match(device) and NAME.match(node)):
            raise FrameError("bad_frames", f"bad radio or node name: {text!r}")
        if kind == "DROP":
            if "/" not in device or "/" in node:
                raise FrameError("bad_frames", f"DROP needs <agent>/<dispenser> and a "
                                 f"node id: {text!r}")
            return RadioEvent(t, "DROP", device, node)
        try:
            rssi = float(parts[3])
        except ValueError:
            raise FrameError("bad_frames", f"non-numeric RSSI: {text!r}") from None
        if not math.isfinite(rssi):
            raise FrameError("bad_frames", f"RSSI is not finite: {text!r}")
        if _node(device) == _node(node):
            raise FrameError("bad_frames", f"a radio cannot hear itself: {text!r}")
        return RadioEvent(t, "RSSI", device, node, rssi)

    def line_fields(self, e: RadioEvent) -> list[str]:
        """The line of an event (no terminator), RSSI to 0.1 dB."""
        fields = [e.kind, e.device, e.node]
        if e.kind == "RSSI":
            fields.append(f"{e.rssi_dbm:.1f}")
        return fields
