"""The commander's live view in the browser, served by the field kit (localhost by default)."""
from __future__ import annotations

import sys

from ..contract import NoBuilding, Params, Sink, param
from ..liveview.server import LiveViewServer, ViewState, building_json
from ..liveview.status import StatusParams, StatusTracker
from ..messages import Diagnostic, PoseEstimate, Tick


class LiveViewSink(Sink):
    """Browser view: floor plan, tracks, positions with 95 % ellipses, stale/alarm states, timeline."""

    name = "live_view"
    inputs = (PoseEstimate, Diagnostic)

    class Params(StatusParams):
        host: str = param("127.0.0.1", description="address to serve on (localhost by "
                          "default: the page has no login; use 0.0.0.0 only on a closed network)")
        port: int = param(8765, ge=0, le=65535, description="TCP port (0: any free port)")
        push_period: float = param(0.25, unit="s", gt=0, description="at most one browser "
                                   "update per connection this often")
        max_points: int = param(20000, gt=0, description="track points kept per firefighter")

    @classmethod
    def tick_period(cls, params: Params) -> float:
        return 1.0  # the status clock (stale / man-down) advances with the timeline

    def start(self) -> None:
        self.state = ViewState(StatusTracker.from_params(self.params),
                               max_points=self.params.max_points)
        try:
            self.state.building = building_json(self.ctx.building)
        except NoBuilding:  # tracks on a blank grid
            pass
        self.server = LiveViewServer(self.state, self.params.host, self.params.port,
                                     self.params.push_period)
        self.server.start()
        self.url = self.server.url
        print(f"[firenav] live view: {self.url}", file=sys.stderr, flush=True)

    def handle(self, stream: str, msg) -> None:
        if isinstance(msg, PoseEstimate):
            self.state.add_pose(msg)
        elif isinstance(msg, Diagnostic):
            self.state.add_diagnostic(msg)
        elif isinstance(msg, Tick):
            self.state.tick(msg.t)

    def finish(self) -> None:
        self.server.close()

