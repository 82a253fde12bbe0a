"""UWB ranges to the building's fixed anchors, as the constraints that use them read them.

Shared by ``orca`` (its missed-door rule chooses the door that fits the ranges) and
``anchor_range`` (the ranges correct the position): which end of a :class:`Range` is a
known anchor, where that anchor is, and which ranges are unusable
(:class:`AnchorRanges`), and the constraint's range input that screens them
(:class:`AnchorRangeInput`).
"""
from __future__ import annotations

import math
from abc import abstractmethod
from typing import Callable

import numpy as np

from firenav_framework import Params, Range, param
from firenav_framework.capabilities.odometry_correction import OdometryCorrection

__all__ = ["AnchorRangeInput", "AnchorRanges", "TagParams"]


class TagParams(Params):
    """The worn UWB tag, as every constraint that reads anchor ranges needs it."""

    tag_height: float = param(1.4, unit="m")
    """height of the UWB tag above the floor (worn on the chest or shoulder), for the expected
    range to an anchor"""


class AnchorRanges:
    """The building's anchor positions (3,) ENU [m] and floors by anchor id, and the range
    screen."""

    def __init__(self, building) -> None:
        self.positions: dict[str, np.ndarray] = {
            a.id: np.asarray(a.position, float) for a in building.anchors}
        self.floors: dict[str, int] = {a.id: int(a.floor) for a in building.anchors}

    def anchor_of(self, msg: Range, count: Callable[[str], None]) -> str | None:
        """The anchor end of a usable range, or None after counting why it is not usable
        (``ranges_unknown_anchor``: neither end is an anchor of the building;
        ``ranges_invalid``: a non-finite or negative range or a sigma not above 0)."""
        anchor = (msg.b if msg.b in self.positions
                  else msg.a if msg.a in self.positions else None)
        if anchor is None:
            count("ranges_unknown_anchor")
            return None
        if not (math.isfinite(msg.range_m) and msg.range_m >= 0 and msg.sigma_m > 0):
            count("ranges_invalid")
            return None
        return anchor


class AnchorRangeInput(OdometryCorrection):
    """An odometry correction that reads UWB ranges to the building's anchors.

    On ``start`` it takes the building and its anchors; every :class:`Range` message of
    its input is screened (:meth:`AnchorRanges.anchor_of`) and a usable one handed to
    :meth:`take_range` with the anchor it reaches.
    """

    inputs = (Range,)
    needs_building = True

    def start(self) -> None:
        self._building = self.ctx.building
        self._anchors = AnchorRanges(self._building)

    def handle(self, stream: str, msg: Range) -> None:
        if not isinstance(msg, Range):
            return
        anchor = self._anchors.anchor_of(msg, self.ctx.count)
        if anchor is not None:
            self.take_range(msg, anchor)

    @abstractmethod
    def take_range(self, msg: Range, anchor: str) -> None:
        """Keep a usable range ``msg`` to anchor ``anchor`` (id) for the steps to come."""
