"""What the sensor counts and reports, by name: screening results and frame problems.

Every problem is counted (``ctx.count``: the run summary); the serious ones are also
reported as diagnostics ``imu_<name>``, rate-limited per device and problem
(``ctx.report``: the first at once, then at most one per ``report_interval`` of data
time with the counts in between summed).
"""
from __future__ import annotations

from collections.abc import Iterator

from firenav_framework.contract import Context

from .screening import Screening

__all__ = ["SCREEN_REPORTS", "FRAME_REPORTS", "screening_problems", "frame_problem"]

#: Screening counts -> (run-summary name, diagnostic text or None for count only).
SCREEN_REPORTS = {
    "nonfinite": ("nonfinite_samples", "samples with NaN/inf values dropped"),
    "out_of_range": ("out_of_range_samples", "samples beyond the plausible range dropped"),
    "time_outlier": ("time_outlier_samples", "samples with a corrupt timestamp dropped"),
    "duplicate": ("duplicate_samples", None),
    "time_backwards": ("time_backwards_samples", "samples whose time went backwards dropped"),
    "saturated": ("saturated_samples", "saturated samples (kept, flagged)"),
    "gaps": ("gaps", "gaps in the data"),
}
#: Frame problems (FrameError codes, codec counts, clocks) -> (diagnostic level, text).
FRAME_REPORTS = {
    "bad_frames": ("warning", "frames that could not be decoded skipped"),
    "checksum_errors": ("warning", "frames with a wrong checksum skipped"),
    "unknown_can_ids": ("info", "CAN frames with ids the DBC does not describe skipped "
                                "(other devices on the bus, or a node missing from the DBC)"),
    "raw_imu_unscaled": ("error", "RAW_IMU packets skipped: set the mavlink_imu codec's "
                                  "raw_accel_scale and raw_gyro_scale"),
    "incomplete_samples": ("warning", "samples missing some of their CAN frames dropped"),
    "clock_resyncs": ("warning", "device clock jumps: time re-anchored to the frames"),
}


def screening_problems(result: Screening) -> Iterator[tuple[str, str, int, str | None]]:
    """``(name, run-summary name, count, diagnostic text or None)`` of every non-zero
    screening count."""
    for key, n in result.counts.items():
        if n:
            what, text = SCREEN_REPORTS[key]
            yield key, what, n, text


def frame_problem(ctx: Context, t: float, code: str, detail: str = "", *, n: int = 1,
                  agent: str = "", key: str = "", every: float = 10.0) -> None:
    """Count ``n`` frame problems ``code`` and report them for ``key`` (a device or link).

    Codes no table lists (a vendor codec's own) are reported as warnings.
    """
    ctx.count(code, n)
    level, text = FRAME_REPORTS.get(code, ("warning", f"frames skipped ({code})"))
    ctx.report(t, f"imu_{code}", f"{text}; {detail}" if detail else text, n=n, agent=agent,
               key=key or "?", level=level, every=every)
