"""Which output stream a frame device feeds, and that device's clock."""
from __future__ import annotations

import fnmatch
from collections.abc import Callable

from firenav_framework.contract import Context

from .clock import DeviceClock
from .params import Frames
from .streams import DeviceStream

__all__ = ["DeviceRoutes"]


class DeviceRoutes:
    """Frame device ids (``can0/node2``, ``sys3/comp1/imu0`` ...) -> output streams.

    A device's agent comes from ``agent_map`` (first matching pattern), else from the
    frame (a source that knows it), else ``default_agent``; its output device is the
    mapped ``agent/device``, else ``<agent>/imu``. Two frame devices that would share an
    output device are kept apart: the second is published as ``<agent>/<raw id>``, with
    a warning. Each frame device has its own :class:`DeviceClock`.
    """

    def __init__(self, frames: Frames, ctx: Context,
                 make_stream: Callable[[str, str, str], DeviceStream]):
        self.frames = frames
        self.ctx = ctx
        self.make_stream = make_stream
        self._routes: dict[str, tuple[DeviceStream, DeviceClock]] = {}
        self._claimed: dict[str, str] = {}   # output device -> raw device id

    def route(self, raw_id: str, frame_agent: str, t: float) -> tuple[DeviceStream, DeviceClock]:
        """The stream and clock of frame device ``raw_id`` (``t`` [s]: for a warning)."""
        route = self._routes.get(raw_id)
        if route is not None:
            return route
        target = next((v for pattern, v in self.frames.agent_map.items()
                       if fnmatch.fnmatchcase(raw_id, pattern)),
                      frame_agent or self.frames.default_agent)
        agent, _, name = target.partition("/")
        device = target if name else f"{agent}/imu"
        other = self._claimed.get(device)
        if other is not None:
            renamed = f"{agent}/{raw_id}"
            self.ctx.warn_once(t, "imu_device_clash", f"{raw_id} and {other} both map to "
                               f"{device}; {raw_id} is published as {renamed}: name each "
                               "device in agent_map", agent=agent, key=raw_id)
            device = renamed
        self._claimed[device] = raw_id
        route = (self.make_stream(agent, device, raw_id), DeviceClock(self.frames.clock_resync))
        self._routes[raw_id] = route
        return route

    def reset(self, agent: str) -> None:
        """Forget the routes (and clocks) of ``agent``'s devices."""
        self._routes = {k: r for k, r in self._routes.items() if r[0].agent != agent}
        self._claimed = {k: raw for k, raw in self._claimed.items() if raw in self._routes}
