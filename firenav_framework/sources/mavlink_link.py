"""Live MAVLink source (pymavlink, MAVLink 2): raw packets for the sensors' codecs."""
from __future__ import annotations

from pathlib import Path
from typing import Any

from ..contract import param
from ..transports.live_source import LiveParams, LiveSource
from ..transports.mavlink_link import MavlinkLink
from ..transports.recorders import TlogRecorder


class MavlinkSource(LiveSource):
    """Live MAVLink link (udpin/udpout/tcp/serial): HIGHRES_IMU, SCALED_IMU, RAW_IMU, heartbeats."""

    name = "mavlink"

    class Params(LiveParams):
        url: str = param("udpin:127.0.0.1:14550")
        """pymavlink connection string (udpin:HOST:PORT, udpout:HOST:PORT, tcp:HOST:PORT,
        tcpin:HOST:PORT, /dev/ttyUSB0)"""
        baud: int = param(115200, gt=0, unit="bit/s")
        """serial baud rate"""
        source_system: int = param(255, ge=1, le=255)
        """our system id in the heartbeats we send"""
        heartbeat_s: float = param(1.0, ge=0, unit="s")
        """send a GCS heartbeat this often (0: never)"""

    def make_link(self) -> MavlinkLink:
        p = self.params
        return MavlinkLink(p.url, baud=p.baud, source_system=p.source_system,
                           heartbeat_s=p.heartbeat_s)

    def make_recorder(self, folder: Path, **kw: Any) -> TlogRecorder:
        return TlogRecorder(folder, "mavlink", **kw)
