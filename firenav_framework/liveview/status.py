"""Per-firefighter status for the commander: stale, untrustworthy, man-down.

The tracker's clock is the pipeline's timeline clock, read from :class:`Tick`
messages (and diagnostics), never the wall clock, so a replay shows the same states
as the live run it came from. Pose times are only used to order a track.

``stale``
    the firefighter's device is reported silent (an active ``device_silent``
    diagnostic naming the agent, from a live source's link monitor), or no pose
    arrived for ``stale_after`` seconds.
``untrusted``
    the latest pose has ``trusted=False`` or a ``map_error`` diagnostic for the agent
    is active.
``man_down``
    the firefighter has not moved more than ``still_radius`` metres for
    ``man_down_after`` seconds while the device is alive (NFPA 1982 PASS devices
    alarm after 30 s without motion; the default follows it).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..contract import Params, param
from ..messages import Diagnostic, PoseEstimate

FLAGS = ("stale", "untrusted", "man_down")


class StatusParams(Params):
    """When a firefighter is shown stale or in alarm: the parameters every sink that
    shows the status shares (``live_view``, ``mavlink_out``)."""

    stale_after: float = param(10.0, unit="s", gt=0, description="no pose for this long "
                               "marks the track stale (a silent device does at once)")
    man_down_after: float = param(30.0, unit="s", gt=0, description="no motion for this "
                                  "long raises the man-down alarm (NFPA 1982 PASS: 30 s)")
    still_radius: float = param(0.5, unit="m", gt=0, description="moving less than this "
                                "counts as no motion")


@dataclass
class AgentStatus:
    """What the commander sees of one firefighter (positions ENU metres)."""

    agent: str
    pose: PoseEstimate | None = None
    last_pose_at: float = -math.inf  # timeline clock at the last pose [s]
    anchor: np.ndarray | None = None  # where the firefighter last moved to
    anchor_at: float = -math.inf      # timeline clock when they got there [s]
    silent_devices: set[str] = field(default_factory=set)
    map_error: bool = False
    flags: dict[str, bool] = field(default_factory=lambda: dict.fromkeys(FLAGS, False))


class StatusTracker:
    """Derives the flags of every firefighter from poses, diagnostics and the clock."""

    def __init__(self, *, stale_after: float = 10.0, man_down_after: float = 30.0,
                 still_radius: float = 0.5):
        self.stale_after = stale_after
        self.man_down_after = man_down_after
        self.still_radius = still_radius
        self.agents: dict[str, AgentStatus] = {}
        self.now = -math.inf

    @classmethod
    def from_params(cls, p: StatusParams) -> "StatusTracker":
        """A tracker with the thresholds of a sink's :class:`StatusParams`."""
        return cls(stale_after=p.stale_after, man_down_after=p.man_down_after,
                   still_radius=p.still_radius)

    def _get(self, agent: str) -> AgentStatus:
        st = self.agents.get(agent)
        if st is None:
            st = self.agents[agent] = AgentStatus(agent)
        return st

    def clock(self, t: float) -> list[tuple[str, str, bool]]:
        """Advance the timeline clock to ``t`` [s]; returns flag changes (agent, flag, on)."""
        if t > self.now:
            if self.now == -math.inf:  # poses that came before the first tick: now
                for st in self.agents.values():
                    st.last_pose_at = max(st.last_pose_at, t) if st.pose else st.last_pose_at
                    st.anchor_at = max(st.anchor_at, t) if st.anchor is not None else st.anchor_at
            self.now = t
        return self._update()

    def pose(self, msg: PoseEstimate) -> list[tuple[str, str, bool]]:
        st = self._get(msg.agent)
        st.pose = msg
        st.last_pose_at = self.now
        pos = np.asarray(msg.position, dtype=float)
        if st.anchor is None or np.hypot(*(pos[:2] - st.anchor[:2])) > self.still_radius \
                or abs(pos[2] - st.anchor[2]) > self.still_radius:
            st.anchor, st.anchor_at = pos, self.now
        return self._update()

    def diagnostic(self, msg: Diagnostic) -> list[tuple[str, str, bool]]:
        if msg.agent:
            st = self._get(msg.agent)
            if msg.code == "device_silent":
                key = msg.device or msg.component
                (st.silent_devices.add if msg.active else st.silent_devices.discard)(key)
            elif msg.code == "map_error":
                st.map_error = msg.active
        return self._update()

    def _update(self) -> list[tuple[str, str, bool]]:
        changes = []
        for st in self.agents.values():
            silent = bool(st.silent_devices)
            new = {
                "stale": silent or (st.pose is not None
                                    and self.now - st.last_pose_at >= self.stale_after),
                "untrusted": st.map_error or (st.pose is not None and not st.pose.trusted),
                "man_down": (not silent and st.anchor is not None
                             and self.now - st.anchor_at >= self.man_down_after),
            }
            for flag, on in new.items():
                if st.flags[flag] != on:
                    st.flags[flag] = on
                    changes.append((st.agent, flag, on))
        return changes
