"""Device clocks onto the pipeline clock, for samples decoded from frames."""
from __future__ import annotations

import math

__all__ = ["DeviceClock"]


class DeviceClock:
    """Maps one device's sample clock onto the pipeline clock.

    Device timestamps are regular where frame times (often receive times) jitter, so
    samples keep their device time, shifted by an offset fixed at the first sample
    (``frame.t - t_device``). A device clock that steps back by more than ``resync``
    seconds (a reboot, a counter wrap; a re-sent burst of frames steps back less and is
    left to the duplicate screening) or leaps forward by more than ``resync`` beyond the
    frame time's own step is re-anchored, once the next sample confirms the new clock:
    it continues the first one, in pace with the frames. Until then the sample off the
    old clock is mapped with the old offset (never later than the newest pipeline
    time), so that the screening drops it as a duplicate or as time going backwards:
    stale samples a second sender re-sends, interleaved with the device's own or in a
    burst, never re-anchor the clock. A confirmed re-anchor costs the first sample of
    the new clock; the second takes the frame time, but never less than one sample
    interval after the device's last pipeline time: the device's time must not step
    back (its later samples would be dropped) when the first frame arrived late. A link
    that stalls and then delivers a backlog does not trigger any of this.
    """

    def __init__(self, resync: float):
        self.resync = resync
        self.offset: float | None = None
        self._last: tuple[float, float] | None = None  # (device t, frame t)
        self._interval = 0.0                            # last positive device time step
        self._candidate: tuple[float, float] | None = None  # a sample off the current clock

    def to_pipeline(self, t_device: float, t_frame: float) -> tuple[float, bool]:
        """(pipeline time of the sample, whether the offset was re-anchored).

        A non-finite device time is passed through (the screening drops it).
        """
        if not math.isfinite(t_device) or not math.isfinite(t_frame):
            return t_device + (self.offset or 0.0), False
        if self._last is None or self.offset is None:
            self.offset = t_frame - t_device
            self._last = (t_device, t_frame)
            return t_device + self.offset, False
        d_dev = t_device - self._last[0]
        if not (d_dev < -self.resync or d_dev - (t_frame - self._last[1]) > self.resync):
            self._candidate = None                      # the current clock goes on
            if d_dev > 0:
                self._interval = d_dev
            self._last = (t_device, t_frame)
            return t_device + self.offset, False
        last_pipeline = self._last[0] + self.offset
        c, self._candidate = self._candidate, (t_device, t_frame)
        step = None if c is None else t_device - c[0]
        if step is None or not (0 < step <= self.resync and t_frame - c[1] >= step / 2):
            return min(t_device + self.offset, last_pipeline), False   # not (yet) confirmed
        self._candidate = None
        self.offset = max(t_frame, last_pipeline + self._interval) - t_device
        self._interval = step
        self._last = (t_device, t_frame)
        return t_device + self.offset, True
