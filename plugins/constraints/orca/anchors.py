"""The building's fixed UWB anchors and floor levels, as the ORCA-family constraints see them."""
from __future__ import annotations

import math
from typing import Callable

import numpy as np

from firenav_framework import Range

__all__ = ["AnchorSite"]


class AnchorSite:
    """Anchor positions (ENU [m]) by id, and the floor a height belongs to."""

    def __init__(self, building):
        self.building = building
        self.positions: dict[str, np.ndarray] = {
            a.id: np.asarray(a.position, float) for a in building.anchors}

    def floor_index(self, z: float) -> int:
        """Index of the floor whose level is nearest below/above height ``z`` [m]."""
        return self.building.floor_of_z(z)

    def floor_at(self, z: float):
        """The floor (``Floor``) whose level is nearest below/above height ``z`` [m]."""
        return self.building.floors[self.floor_index(z)]

    def usable_anchor(self, msg: Range, count: Callable[[str], None]) -> str | None:
        """The anchor end of a usable range, or None after counting why it is not usable."""
        anchor = (msg.b if msg.b in self.positions
                  else msg.a if msg.a in self.positions else None)
        if anchor is None:
            count("ranges_unknown_anchor")
            return None
        if not (math.isfinite(msg.range_m) and msg.range_m >= 0 and msg.sigma_m > 0):
            count("ranges_invalid")
            return None
        return anchor
