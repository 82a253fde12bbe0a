"""Extension template for a firenav SENSOR: the data of one kind of device, conditioned.

How to use it:

1. Copy this file into your package (``acme_firenav/sensor.py``) and rename the class
   to ``<Device>Sensor``; work through the ``TODO`` markers.
2. Register the class in your package's ``pyproject.toml``::

       [project.entry-points."firenav.plugins"]
       "sensor.acme_range" = "acme_firenav.sensor:AcmeRangeSensor"

3. Run the conformance suite in your tests, one call::

       from firenav_framework.testing import check_plugin
       def test_conforms():
           check_plugin(AcmeRangeSensor)

As it is, the class is a working example: it calibrates UWB-style ranges (a constant
bias) and drops impossible ones, and it passes ``check_plugin``.

The contract (``firenav_framework/contract/sensor.py`` says it all):

* Input: raw device data (``RawFrame`` from a live link or its log) or device messages
  from a recording or the simulator. Decode wire formats with a registered codec, never
  with a private parser: declare a ``CodecSelection`` parameter group and decode with
  ``TransportCodecs(params.frames, count=ctx.count).decode(frame)``
  (``firenav_framework.codecs.selection``; it counts frames of other transports and
  other devices' records, and raises the codec's ``FrameError`` for a broken one).
* Output: typed measurements in SI units and the conventions of
  ``firenav_framework.messages`` (ENU, FLU, radians, seconds).
* Bad input (a frame that does not decode, a NaN, a sample out of time order) is
  COUNTED (``ctx.count``) and REPORTED rate-limited (``ctx.report``), and skipped; it
  never raises and never affects another device.
* State per firefighter lives in ``PerAgent``, so ``reset(agent)`` forgets exactly one.
* Messages are shared: never change a received message or its arrays in place.
"""
from __future__ import annotations

import math

from firenav_framework import Message, Params, PerAgent, Range, Sensor, param

# TODO: import the message types your device produces and your sensor publishes.


class MyRangeSensor(Sensor):
    """Ranging radio: ranges corrected for the radio's bias, impossible ones dropped."""

    # TODO: the name pipelines use (``plugin: my_range``); unique among sensors.
    name = "my_range"
    # TODO: the message types the sensor accepts on its input streams.
    inputs = (Range,)
    # TODO: output ports and their message types (a "diagnostics" port is always there).
    outputs = {"range": Range}

    class Params(Params):
        # TODO: every parameter: a default, an SI unit where it is a quantity, and its
        # description as the docstring right below it (they are the YAML schema and the
        # `firenav plugins show` table).
        # Angles are declared `Angle` / `AngularRate` (radians; YAML may say "5 deg").
        offset: float = param(0.0, unit="m")
        """bias of the radio, subtracted from every range"""
        max_range: float = param(100.0, unit="m", gt=0)
        """longer ranges are impossible for this radio and dropped (counted)"""

    def __init__(self, params: Params, ctx):
        super().__init__(params, ctx)
        # Per firefighter: device -> time [s] of its last range (for time order).
        self._last: PerAgent[dict[str, float]] = PerAgent(lambda agent: {})

    def handle(self, stream: str, msg: Message) -> None:
        # TODO: decode and condition one message. Called in time order, once per message.
        if not isinstance(msg, Range):
            self.ctx.count("ignored_messages")
            return
        last = self._last[msg.agent]
        if msg.device in last and msg.t < last[msg.device]:
            self._skip(msg, "out_of_order", "ranges older than their device's last one")
            return
        if not (math.isfinite(msg.range_m) and math.isfinite(msg.sigma_m)):
            self._skip(msg, "non_finite", "ranges with NaN or infinite values")
            return
        corrected = msg.range_m - self.params.offset
        if not 0.0 <= corrected <= self.params.max_range:
            self._skip(msg, "out_of_range", f"ranges outside 0..{self.params.max_range:g} m")
            return
        last[msg.device] = msg.t
        self.ctx.publish("range", Range(t=msg.t, agent=msg.agent, device=msg.device, a=msg.a,
                                        b=msg.b, range_m=corrected, sigma_m=msg.sigma_m,
                                        method=msg.method, nlos=msg.nlos))

    def _skip(self, msg: Message, code: str, text: str) -> None:
        """Count a dropped message and report it (at most every 10 s of data per device)."""
        self.ctx.count(code)
        self.ctx.report(msg.t, code, f"{text} dropped", agent=msg.agent, key=msg.device)

    def reset(self, agent: str) -> None:
        # TODO: forget everything about this firefighter (the `restart` fault policy).
        self._last.reset(agent)
