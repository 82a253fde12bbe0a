"""Live serial line source: one RawFrame per text line of a vendor device (UWB, RFID)."""
from __future__ import annotations

from pathlib import Path
from typing import Any

from ..contract import param
from ..transports.line_links import SerialLineLink
from ..transports.live_source import LiveParams, LiveSource
from ..transports.recorders import LinesRecorder


class LineParams(LiveParams):
    """Framing of line protocols."""

    terminator: str = param("\n", min_length=1, description="line terminator "
                            "(YAML escapes like \"\\r\\n\" work)")
    max_line: int = param(4096, gt=0, le=1 << 20, unit="B")
    """longer lines are decode errors"""


class SerialLinesSource(LiveSource):
    """Live serial port (or pyserial URL) read line by line into RawFrames."""

    name = "serial_lines"

    class Params(LineParams):
        url: str = param()
        """serial port or pyserial URL (/dev/ttyUSB0, loop://, socket://HOST:PORT)"""
        baudrate: int = param(115200, gt=0, unit="bit/s")
        """baud rate"""
        device: str = param("")
        """device name for RawFrame.device and the logs (default: the port's file name)"""

    def make_link(self) -> SerialLineLink:
        p = self.params
        device = p.device or Path(p.url.split("://")[-1]).name or "serial"
        return SerialLineLink(p.url, device=device.replace(" ", "_"), baudrate=p.baudrate,
                              terminator=p.terminator.encode(), max_line=p.max_line)

    def make_recorder(self, folder: Path, **kw: Any) -> LinesRecorder:
        return LinesRecorder(folder, "serial", **kw)
