"""Encounters (breadcrumb paper §V-A): a firefighter passing a node, found at the RSSI peak."""
from __future__ import annotations

from dataclasses import dataclass

from firenav_framework import Params, param

__all__ = ["EncounterRules", "Episode", "EncounterDetector"]


class EncounterRules(Params):
    """What makes an encounter episode and when its peak is confirmed."""

    dbm: float = param(-40.0, unit="dBm")
    """an encounter episode is RSSI at or above this (§V-A)"""
    hysteresis_db: float = param(3.0, unit="dB", ge=0)
    """the peak is confirmed once the RSSI falls this far below it"""
    max_gap_s: float = param(3.0, unit="s", gt=0)
    """an episode ends when the link is quiet this long"""
    sigma_m: float = param(1.0, unit="m", gt=0)
    """position agreement of an encounter, per axis"""


@dataclass
class Episode:
    """An encounter episode of one pair: RSSI above the threshold, peak so far."""

    peak_dbm: float
    peak_t: float
    agent: str
    device: str


class EncounterDetector:
    """Episodes of RSSI at or above ``rules.dbm`` per node pair, closed at their peak."""

    def __init__(self, rules: EncounterRules):
        self.rules = rules
        self._episodes: dict[tuple[str, str], Episode] = {}
        self._last_heard: dict[tuple[str, str], float] = {}

    def reading(self, pair: tuple[str, str], t: float, rssi: float, agent: str,
                device: str) -> list[tuple[tuple[str, str], Episode]]:
        """One RSSI [dBm] of ``pair`` at ``t`` [s] (``agent``: the firefighter of the pair
        or ''); the episodes it closes."""
        rules = self.rules
        closed = []
        ep = self._episodes.get(pair)
        last = self._last_heard.get(pair)
        self._last_heard[pair] = t
        if ep is not None and last is not None and t - last > rules.max_gap_s:
            closed.append((pair, self._episodes.pop(pair)))
            ep = None
        if rssi >= rules.dbm:
            if ep is None:
                self._episodes[pair] = Episode(rssi, t, agent, device)
            elif rssi > ep.peak_dbm:
                ep.peak_dbm, ep.peak_t = rssi, t
        elif ep is not None and rssi <= ep.peak_dbm - rules.hysteresis_db:
            closed.append((pair, self._episodes.pop(pair)))
        return closed

    def close_all(self) -> list[tuple[tuple[str, str], Episode]]:
        """Every open episode (end of input)."""
        closed = list(self._episodes.items())
        self._episodes.clear()
        return closed
