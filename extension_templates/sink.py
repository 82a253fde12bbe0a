"""Extension template for a firenav SINK: a consumer of streams (files, links, displays).

How to use it:

1. Copy this file into your package and rename the class ``<Name>Sink``; work through
   the ``TODO`` markers.
2. Register it: ``"sink.my_pose_log" = "acme_firenav.sink:MySink"``.
3. Test it with ``firenav_framework.testing.check_plugin(MySink)``.

As it is, the class is a working example: every pose estimate as one line of a CSV
file in the run's output folder. It passes ``check_plugin``.

The contract (``firenav_framework/contract/sink.py``):

* Input: any streams (wildcards allowed in the pipeline: ``input: "*.pose"``).
* Files only under the run's output folder: ``FileSink.out_path(name)`` refuses
  anything else.
* Never hold up the pipeline: slow work off the pipeline thread or at ``finish``.
* Nothing is lost: write what arrives (a NaN pose too: the file says what the
  estimator said), count what cannot be written, never raise.
"""
from __future__ import annotations

import math

from firenav_framework import FileSink, Message, Params, PoseEstimate, param


class MySink(FileSink):
    """Pose log: every pose estimate as a CSV line (t, agent, x, y, z, heading)."""

    # TODO: the name pipelines use; unique among sinks.
    name = "my_pose_log"
    # TODO: the message types it accepts.
    inputs = (PoseEstimate,)

    class Params(Params):
        # TODO: your parameters.
        file: str = param("poses.csv")
        """file name, in the run's output folder"""
        digits: int = param(3, ge=0, le=9)
        """decimals of positions [m] and headings [rad]"""

    def start(self) -> None:
        self._out = self.out_path(self.params.file).open("w", encoding="utf-8")
        self._out.write("t,agent,x,y,z,heading\n")

    def handle(self, stream: str, msg: Message) -> None:
        # TODO: consume one message.
        if not isinstance(msg, PoseEstimate):
            self.ctx.count("ignored_messages")
            return
        d = self.params.digits
        values = [*(float(v) for v in msg.position), float(msg.heading)]
        if not all(math.isfinite(v) for v in values):
            self.ctx.count("non_finite_poses")      # written as they came, and counted
        cells = ",".join(f"{v:.{d}f}" for v in values)
        self._out.write(f"{msg.t:.3f},{msg.agent},{cells}\n")

    def finish(self) -> None:
        self._out.close()

    def reset(self, agent: str) -> None:
        # TODO: forget this firefighter (this sink keeps nothing per firefighter).
        pass
