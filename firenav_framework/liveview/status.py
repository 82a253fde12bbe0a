"""Per-firefighter conditions for the commander: what holds *now*, on the timeline clock.

The tracker's clock is the pipeline's timeline clock, read from :class:`Tick`
messages (and diagnostics), never the wall clock, so a replay shows the same
conditions as the live run it came from. Pose times are only used to order a track.
Conditions are the inputs of the latched alarms (:mod:`.alarms`); they come and go,
an alarm stays until a person acknowledges it.

``device_silent``
    a device of the firefighter is reported silent (an active ``device_silent``
    diagnostic naming the agent, from a live source's link monitor).
``man_down``
    the firefighter has not moved more than ``still_radius`` metres for
    ``man_down_after`` seconds (NFPA 1982 PASS devices alarm after 30 s without motion;
    the default follows it). While a device of the firefighter is silent nothing is
    known about motion, so the condition keeps the value it had when the device went
    silent: silence never clears a man-down.
``untrusted``
    the firefighter's poses have had ``trusted=False`` for ``untrusted_after`` seconds
    (a single untrusted pose, e.g. while a particle filter converges, is not a
    condition).
``map_contradiction``
    an estimator reports that the firefighter's motion contradicts the floor plan (an
    active ``map_error`` diagnostic for the agent).

``stale`` (no pose for ``stale_after`` seconds) is shown on the track but is no
condition: an estimator that publishes a pose per stride publishes nothing while the
firefighter stands still.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..contract import Params, param
from ..messages import Diagnostic, PoseEstimate

CONDITIONS = ("device_silent", "man_down", "untrusted", "map_contradiction")

#: (agent, condition, on) as the tracker reports a change.
Change = tuple[str, str, bool]


class StatusParams(Params):
    """When a firefighter is in alarm: the parameters every sink that shows the
    status shares (``live_view``, ``mavlink_out``)."""

    stale_after: float = param(10.0, unit="s", gt=0)
    """no pose for this long draws the track as stale"""
    man_down_after: float = param(30.0, unit="s", gt=0)
    """no motion for this long raises the man-down alarm (NFPA 1982 PASS: 30 s)"""
    still_radius: float = param(0.5, unit="m", gt=0)
    """moving less than this counts as no motion"""
    untrusted_after: float = param(5.0, unit="s", ge=0)
    """poses untrusted for this long raise the untrusted-position alarm"""


@dataclass
class AgentStatus:
    """What the commander sees of one firefighter (positions ENU metres)."""

    agent: str
    pose: PoseEstimate | None = None
    last_pose_at: float = -math.inf  # timeline clock at the last pose [s]
    anchor: np.ndarray | None = None  # where the firefighter last moved to
    anchor_at: float = -math.inf      # timeline clock when they got there [s]
    untrusted_since: float | None = None  # timeline clock of the first untrusted pose
    silent_devices: set[str] = field(default_factory=set)
    map_error: bool = False
    conditions: dict[str, bool] = field(default_factory=lambda: dict.fromkeys(CONDITIONS,
                                                                              False))

    def stale(self, now: float, stale_after: float) -> bool:
        """No pose for ``stale_after`` [s], or a silent device."""
        return bool(self.silent_devices) or (self.pose is not None
                                             and now - self.last_pose_at >= stale_after)


class StatusTracker:
    """Derives the conditions of every firefighter from poses, diagnostics and the clock."""

    def __init__(self, *, stale_after: float = 10.0, man_down_after: float = 30.0,
                 still_radius: float = 0.5, untrusted_after: float = 5.0):
        self.stale_after = stale_after
        self.man_down_after = man_down_after
        self.still_radius = still_radius
        self.untrusted_after = untrusted_after
        self.agents: dict[str, AgentStatus] = {}
        self.now = -math.inf

    @classmethod
    def from_params(cls, p: StatusParams) -> "StatusTracker":
        """A tracker with the thresholds of a sink's :class:`StatusParams`."""
        return cls(stale_after=p.stale_after, man_down_after=p.man_down_after,
                   still_radius=p.still_radius, untrusted_after=p.untrusted_after)

    def _get(self, agent: str) -> AgentStatus:
        st = self.agents.get(agent)
        if st is None:
            st = self.agents[agent] = AgentStatus(agent)
        return st

    def clock(self, t: float) -> list[Change]:
        """Advance the timeline clock to ``t`` [s]; returns condition changes."""
        if t > self.now:
            if self.now == -math.inf:  # poses that came before the first tick: now
                for st in self.agents.values():
                    st.last_pose_at = max(st.last_pose_at, t) if st.pose else st.last_pose_at
                    st.anchor_at = max(st.anchor_at, t) if st.anchor is not None else st.anchor_at
                    if st.untrusted_since is not None:
                        st.untrusted_since = max(st.untrusted_since, t)
            self.now = t
        changes: list[Change] = []
        for st in self.agents.values():
            changes += self._update(st)
        return changes

    def pose(self, msg: PoseEstimate) -> list[Change]:
        """Take the latest pose of ``msg.agent``; returns condition changes."""
        st = self._get(msg.agent)
        st.pose = msg
        st.last_pose_at = self.now
        pos = np.asarray(msg.position, dtype=float)
        if np.all(np.isfinite(pos)) and (
                st.anchor is None or np.hypot(*(pos[:2] - st.anchor[:2])) > self.still_radius
                or abs(pos[2] - st.anchor[2]) > self.still_radius):
            st.anchor, st.anchor_at = pos, self.now
        if msg.trusted:
            st.untrusted_since = None
        elif st.untrusted_since is None:
            st.untrusted_since = self.now
        return self._update(st)

    def diagnostic(self, msg: Diagnostic) -> list[Change]:
        """Take a diagnostic (``device_silent`` and ``map_error`` name conditions)."""
        if not msg.agent:
            return []
        st = self._get(msg.agent)
        if msg.code == "device_silent":
            key = msg.device or msg.component
            (st.silent_devices.add if msg.active else st.silent_devices.discard)(key)
        elif msg.code == "map_error":
            st.map_error = msg.active
        else:
            return []
        return self._update(st)

    def _update(self, st: AgentStatus) -> list[Change]:
        silent = bool(st.silent_devices)
        man_down = st.conditions["man_down"] if silent else (
            st.anchor is not None and self.now - st.anchor_at >= self.man_down_after)
        new = {
            "device_silent": silent,
            "man_down": man_down,
            "untrusted": st.untrusted_since is not None
                         and self.now - st.untrusted_since >= self.untrusted_after,
            "map_contradiction": st.map_error,
        }
        changes = []
        for cond, on in new.items():
            if st.conditions[cond] != on:
                st.conditions[cond] = on
                changes.append((st.agent, cond, on))
        return changes
