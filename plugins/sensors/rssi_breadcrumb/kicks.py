"""Kicked breadcrumbs (breadcrumb paper §V-B/C): a fixed node whose links all shifted."""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

import numpy as np

from firenav_framework import Params, param

__all__ = ["KickRules", "KickDetector"]


class KickRules(Params):
    """How far and on how many links a fixed node's RSSI must shift to say it moved."""

    db: float = param(6.0, unit="dB", gt=0)
    """shift of a fixed link's median RSSI that says a node moved"""
    window: int = param(8, ge=3)
    """readings per median of a fixed link"""
    min_links: int = param(2, ge=1)
    """fixed links of a node that must shift together"""


@dataclass
class _Link:
    """Recent RSSI of a link between two fixed nodes."""

    reference: float | None = None
    recent: deque = field(default_factory=deque)   # (t, rssi)
    changed_at: float | None = None


class KickDetector:
    """Median RSSI per link between fixed nodes (breadcrumbs, base stations), and the
    nodes whose links moved while their peers' other links stayed put."""

    def __init__(self, rules: KickRules, base_stations: list[str]):
        self.rules = rules
        self.base_stations = set(base_stations)
        self._links: dict[tuple[str, str], _Link] = {}

    def reading(self, pair: tuple[str, str], t: float, rssi: float
                ) -> list[tuple[str, float, int]]:
        """One RSSI [dBm] of the fixed-node ``pair`` at ``t`` [s]; the nodes it shows
        moved, as ``(node, time the change began [s], links shifted)``."""
        rules = self.rules
        link = self._links.setdefault(pair, _Link())
        link.recent.append((t, rssi))
        if len(link.recent) > rules.window:
            link.recent.popleft()
        if len(link.recent) < rules.window:
            return []
        level = float(np.median([r for _, r in link.recent]))
        if link.reference is None:
            link.reference = level
            return []
        moved = []
        if abs(level - link.reference) > rules.db and link.changed_at is None:
            link.changed_at = link.recent[0][0]
            for node in pair:
                found = self._attribute(node)
                if found is not None:
                    moved.append(found)
        return moved

    def _attribute(self, node: str) -> tuple[str, float, int] | None:
        """``node`` moved when enough of its fixed links shifted and the peers' other
        links did not (so it is this node, not a peer, that moved)."""
        if node in self.base_stations:
            return None
        mine = {pair: link for pair, link in self._links.items() if node in pair}
        shifted = {pair: link for pair, link in mine.items() if link.changed_at is not None}
        if len(shifted) < min(self.rules.min_links, len(mine)) or not shifted:
            return None
        if len(mine) == 1 and len(self._links) > 1:
            return None   # one link only: cannot tell which end moved
        for pair in shifted:
            peer = pair[0] if pair[1] == node else pair[1]
            peer_other = [lk for pr, lk in self._links.items() if peer in pr and node not in pr]
            if peer_other and all(lk.changed_at is not None for lk in peer_other):
                return None   # the peer's links moved too: not this node's doing
        t0 = min(link.changed_at for link in shifted.values())
        for link in mine.values():          # new reference levels after the move
            link.reference = float(np.median([r for _, r in link.recent]))
            link.changed_at = None
        return node, t0, len(shifted)
