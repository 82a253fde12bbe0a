"""Tag passes: the reads of one tag by one reader merged into one detection."""
from __future__ import annotations

import math
from dataclasses import dataclass

from firenav_framework import TagDetection

__all__ = ["TagPass", "read_problem"]


@dataclass
class TagPass:
    """The reads of one tag by one reader so far (times [s], RSSI [dBm])."""

    agent: str
    device: str
    reader: str
    tag_id: str
    first: float
    last: float
    reads: int
    peak_t: float
    peak_rssi: float | None

    def add(self, t: float, reads: int, rssi: float | None) -> None:
        self.last = max(self.last, t)
        self.reads += reads
        if rssi is not None and (self.peak_rssi is None or rssi > self.peak_rssi):
            self.peak_rssi, self.peak_t = rssi, t

    def detection(self) -> TagDetection:
        t = self.peak_t if self.peak_rssi is not None else 0.5 * (self.first + self.last)
        return TagDetection(t=t, agent=self.agent, device=self.device, tag_id=self.tag_id,
                            reader=self.reader, rssi_dbm=self.peak_rssi, reads=self.reads)


def read_problem(t: float, agent: str, tag_id: str, reads: int, rssi: float | None) -> str:
    """Why a read cannot be used ('' when it can)."""
    if not math.isfinite(t):
        return "non-finite time"
    if not agent:
        return "no agent for the reader"
    if not tag_id:
        return "empty tag id"
    if not isinstance(reads, int) or reads < 1:
        return f"read count {reads!r}"
    if rssi is not None and not math.isfinite(rssi):
        return "non-finite RSSI"
    return ""

