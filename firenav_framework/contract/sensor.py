"""The sensor role: decode and condition the data of one kind of device.

Contract of a :class:`Sensor`:

* Input: raw device data (:class:`~firenav_framework.messages.RawFrame` from a live
  link or its log, or device-axes messages from a recording or the simulator). Wire
  formats are decoded with a registered codec (:mod:`firenav_framework.codecs`), never
  with a private parser, so the player, the simulator and other sensors share it.
* Output: typed measurements in SI units and the conventions of
  :mod:`firenav_framework.messages` (an IMU block in FLU, a range, a tag read ...).
* Bad input (a frame that does not decode, a NaN, a saturated sample, a clock that
  jumps) is counted per device (``ctx.count``) and reported rate-limited
  (``ctx.report``); it never raises and never affects another device.
* State is per device or per firefighter (:class:`~.context.PerAgent`), so ``reset``
  forgets exactly one firefighter.
"""
from __future__ import annotations

from abc import abstractmethod

from ..messages import Message
from .component import Component

__all__ = ["Sensor"]


class Sensor(Component):
    """Decodes and conditions the data of one kind of device."""

    kind = "sensor"

    @abstractmethod
    def handle(self, stream: str, msg: Message) -> None:
        """Process one message from input ``stream`` (in time order)."""
