"""Map-error detection from the particle spread (search-pattern paper §V-E).

The paper splits a search into periods by whether the filter's horizontal position
variance (var_x + var_y) is above or below 3 m^2: before convergence, converged,
disturbed by a map error, converged again. "Sudden increases in the estimated
position variance can be used to indicate that the filter may have been disturbed
by map errors."

:class:`SpreadMonitor` follows those periods for one firefighter. A rise above the
threshold after the filter has converged once is a suspected map error: the monitor reports
it once when it starts and once when the variance falls back below
``clear_m2`` (equal to the threshold by default, as in the paper).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

__all__ = ["SpreadMonitor", "SpreadState"]

SpreadState = Literal["converging", "converged", "disturbed"]


@dataclass
class SpreadMonitor:
    threshold_m2: float = 3.0
    clear_m2: float = 3.0
    state: SpreadState = "converging"

    def update(self, spread_m2: float) -> Literal["map_error", "recovered"] | None:
        """Feed the current var_x + var_y [m^2]; returns the transition, if any."""
        if self.state == "converged" and spread_m2 > self.threshold_m2:
            self.state = "disturbed"
            return "map_error"
        if self.state == "disturbed" and spread_m2 <= self.clear_m2:
            self.state = "converged"
            return "recovered"
        if self.state == "converging" and spread_m2 <= self.clear_m2:
            self.state = "converged"
        return None
