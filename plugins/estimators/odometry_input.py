"""How the built-in estimators take an Odometry increment in: the one usability rule
(:meth:`~firenav_framework.messages.Odometry.problem`) and time order, with the same
counts and report for every estimator."""
from __future__ import annotations

from firenav_framework import Context, Odometry

__all__ = ["accept_odometry"]


def accept_odometry(ctx: Context, msg: Odometry, last_t: float | None) -> bool:
    """Whether to integrate ``msg``: it must be usable (else counted as ``bad_odometry``
    and reported once per firefighter) and end after ``last_t`` [s], the end of the last
    increment taken for that firefighter (else counted as ``stale_odometry``)."""
    problem = msg.problem()
    if problem:
        ctx.count("bad_odometry")
        ctx.warn_once(msg.t, "bad_odometry", f"odometry skipped: {problem}", agent=msg.agent)
        return False
    if last_t is not None and msg.t <= last_t:
        ctx.count("stale_odometry")
        return False
    return True
