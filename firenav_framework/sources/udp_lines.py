"""Live UDP line source: datagrams of text lines from vendor devices, one RawFrame per line."""
from __future__ import annotations

from pathlib import Path
from typing import Any

from ..contract import param
from ..transports.line_links import UdpLineLink
from ..transports.live_source import LiveSource
from ..transports.recorders import LinesRecorder
from .serial_lines import LineParams


class UdpLinesSource(LiveSource):
    """Live UDP port; each line of each datagram is a RawFrame (device = sender host:port)."""

    name = "udp_lines"

    class Params(LineParams):
        bind: str = param("127.0.0.1:5005")
        """HOST:PORT to listen on (localhost by default; 0.0.0.0 for every interface)"""

    def make_link(self) -> UdpLineLink:
        p = self.params
        return UdpLineLink(p.bind, terminator=p.terminator.encode(), max_line=p.max_line)

    def make_recorder(self, folder: Path, **kw: Any) -> LinesRecorder:
        return LinesRecorder(folder, "udp", **kw)
