"""Range bias model of a UWB anchor (DW1000 ranges read long as the signal weakens)."""
from __future__ import annotations

import numpy as np

from firenav_framework.contract import Params, param

__all__ = ["AnchorBias"]


class AnchorBias(Params):
    """Range bias model of one anchor: ``measured = scale * true + offset_m + b(rx)``."""

    offset_m: float = param(0.0, unit="m")
    """constant bias (antenna delay residue)"""
    scale: float = param(1.0, gt=0.5, lt=1.5)
    """scale factor (clock/propagation)"""
    power_table: list[tuple[float, float]] = param([])
    """(rx_power_dbm, bias_m) points of the power-dependent bias, interpolated linearly (held
    constant beyond the ends)"""

    def correct(self, range_m: float, rx_dbm: float | None) -> float:
        """The bias-corrected range [m] of a raw range [m] received at ``rx_dbm`` [dBm]."""
        b = 0.0
        if self.power_table and rx_dbm is not None:
            pts = sorted(self.power_table)
            b = float(np.interp(rx_dbm, [p[0] for p in pts], [p[1] for p in pts]))
        return (range_m - self.offset_m - b) / self.scale
