"""Device clocks onto the pipeline clock, for samples decoded from frames."""
from __future__ import annotations

import math

__all__ = ["DeviceClock"]


class DeviceClock:
    """Maps one device's sample clock onto the pipeline clock.

    Device timestamps are regular where frame times (often receive times) jitter, so
    samples keep their device time, shifted by an offset fixed at the first sample
    (``frame.t - t_device``). The offset is re-anchored when the device clock
    steps back by more than ``resync`` seconds (a reboot, a counter wrap; a re-sent
    burst of frames steps back less and is left to the duplicate screening) or leaps
    forward by more than ``resync`` beyond the frame time's own step; a link that
    stalls and then delivers a backlog does not trigger it. A re-anchored sample takes
    the frame time, but never less than one sample interval after the device's last
    pipeline time: the device's time must not step back (its later samples would be
    dropped as time going backwards) when the first frame arrived late.
    """

    def __init__(self, resync: float):
        self.resync = resync
        self.offset: float | None = None
        self._last: tuple[float, float] | None = None  # (device t, frame t)
        self._interval = 0.0                            # last positive device time step

    def to_pipeline(self, t_device: float, t_frame: float) -> tuple[float, bool]:
        """(pipeline time of the sample, whether the offset was re-anchored).

        A non-finite device time is passed through (the screening drops it).
        """
        if not math.isfinite(t_device) or not math.isfinite(t_frame):
            return t_device + (self.offset or 0.0), False
        resynced = False
        if self._last is not None:
            d_dev = t_device - self._last[0]
            if d_dev < -self.resync or d_dev - (t_frame - self._last[1]) > self.resync:
                last_pipeline = self._last[0] + self.offset
                self.offset = max(t_frame, last_pipeline + self._interval) - t_device
                resynced = True
            elif d_dev > 0:
                self._interval = d_dev
        if self.offset is None:
            self.offset = t_frame - t_device
        self._last = (t_device, t_frame)
        return t_device + self.offset, resynced
