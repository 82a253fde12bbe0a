"""One output IMU stream: everything the sensor keeps for one (agent, device)."""
from __future__ import annotations

from dataclasses import dataclass, field

from firenav_framework.messages import ImuBlock

from .calibration import LinearCorrection
from .rest_check import RestCheck
from .samples import Samples, hold_leap
from .screening import DeviceHistory, Screening, ScreeningLimits, screen

__all__ = ["DeviceStream"]


@dataclass
class DeviceStream:
    """The corrections (calibration, then the rotation to FLU), screening memory, held
    sample and set-up check of one output stream."""

    agent: str
    device: str
    accel: LinearCorrection
    gyro: LinearCorrection
    mag: LinearCorrection
    history: DeviceHistory = field(default_factory=DeviceHistory)
    held: Samples | None = None   # a last sample that leapt ahead, awaiting its successor
    axes: tuple[str, ...] = ("x", "y", "z")   # the declared mapping, for the rest check
    rest: RestCheck = field(init=False)

    def __post_init__(self) -> None:
        self.rest = RestCheck(self.device, self.axes)

    def condition(self, samples: Samples, limits: ScreeningLimits, final: bool = False
                  ) -> tuple[Screening | None, ImuBlock | None]:
        """Screen, correct and rotate the next samples (device axes, SI, arrival order).

        Returns the screening (None: no samples to screen yet) and the FLU block of the
        samples kept (None: none kept). ``final``: no more input will come, so a last
        sample that leaps ahead is judged now instead of held.
        """
        if self.held is not None:
            samples, self.held = self.held.then(samples), None
        if not final:
            samples, self.held = hold_leap(samples, self.history.last_t, limits.gap)
        if not len(samples):
            return None, None
        result = screen(samples.time, samples.accel, samples.gyro, limits, self.history,
                        samples.flags)
        if not result.keep.any():
            return result, None
        kept = samples.take(result.keep)
        block = ImuBlock(t=float(kept.time[-1]), agent=self.agent, device=self.device,
                         time=kept.time, accel=self.accel(kept.accel),
                         gyro=self.gyro(kept.gyro),
                         mag=None if kept.mag is None else self.mag(kept.mag),
                         flags=result.flags, frame="FLU")
        return result, block
