"""Counters and per-stream message counts gathered during a run, for the summary."""
from __future__ import annotations

from collections import Counter, defaultdict
from dataclasses import dataclass, field


@dataclass
class RunStats:
    """What happened in a run: messages per stream and named counts per component.

    Counts are the only record of skipped or repaired input that is not an error,
    so every plugin that drops something must count it here (via ``ctx.count``).
    """

    messages: Counter = field(default_factory=Counter)
    counts: defaultdict = field(default_factory=lambda: defaultdict(Counter))

    def count(self, component: str, what: str, n: int = 1) -> None:
        self.counts[component][what] += n

    def seen(self, stream: str, n: int = 1) -> None:
        self.messages[stream] += n

    def as_dict(self) -> dict:
        return {
            "messages": dict(sorted(self.messages.items())),
            "counts": {c: dict(sorted(v.items())) for c, v in sorted(self.counts.items()) if v},
        }
