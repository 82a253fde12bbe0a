"""Live CAN source (python-can): raw frames for the sensors to decode with their codecs."""
from __future__ import annotations

from pathlib import Path
from typing import Any

from ..contract import param
from ..transports.can_link import CanLink
from ..transports.live_source import LiveParams, LiveSource
from ..transports.recorders import CAN_LOG_SUFFIXES, CanRecorder


class CanBusSource(LiveSource):
    """Live CAN bus through python-can (socketcan, pcan, kvaser, slcan, virtual, udp_multicast, ...)."""

    name = "can_bus"

    class Params(LiveParams):
        interface: str = param("socketcan")
        """python-can interface name (socketcan, pcan, kvaser, slcan, serial, virtual,
        udp_multicast, ...)"""
        channel: str = param("can0")
        """interface channel (can0, PCAN_USBBUS1, /dev/ttyACM0, loop://, a multicast group, ...)"""
        bitrate: int | None = param(None, gt=0, unit="bit/s")
        """bus bitrate (None: the interface's default or current setting)"""
        device: str = param("")
        """device name put in RawFrame.device and the logs (default: the channel)"""
        options: dict[str, Any] = param({})
        """further keyword arguments for can.Bus (e.g. {port: 43113} for udp_multicast)"""
        record_format: str = param(".log", description="python-can log format of the "
                                   f"recording, by suffix: {', '.join(CAN_LOG_SUFFIXES)} "
                                   "(.log = candump, exact to 1 us)")

    def make_link(self) -> CanLink:
        p = self.params
        if p.record_format.lower() not in CAN_LOG_SUFFIXES:
            raise ValueError(f"record_format '{p.record_format}': choose one of "
                             f"{', '.join(CAN_LOG_SUFFIXES)}")
        return CanLink(p.interface, p.channel, device=p.device, bitrate=p.bitrate,
                       options=p.options)

    def make_recorder(self, folder: Path, **kw: Any) -> CanRecorder:
        return CanRecorder(folder, "can", suffix=self.params.record_format, **kw)
