"""Merging several time-ordered inputs into one, when an input's clock may jump.

A plain merge by time (``heapq.merge``) trusts every input to be in order: one input
whose time jumps back 1000 s (a device clock reset) is emptied up to the other inputs'
time before they get a turn, and one whose time leaps to 1e308 (a corrupt timestamp)
holds back the rest of its own data until every other input has ended. Downstream,
the timeline then finds the held-back data late and drops it: one device's damage
costs everyone.

:func:`merge_in_time` merges by a *continuous* key per input instead: the key follows
the input's time step by step, but a step back by more than ``jump_back`` seconds or
forward by more than ``max_lead`` seconds (a discontinuity) advances the key by the
input's last ordinary step only. An input is thus merged where its data belong in
sequence, while the times themselves are passed on unchanged for the timeline's rules
(clock jumps rebased, corrupt leaps dropped: :mod:`firenav_framework.timeline`), which
continue a jumped channel in the same way. The first item of an input anchors its key
unless the next two items show it to be the odd one out. Items whose time is not
finite keep the key of their predecessor.
"""
from __future__ import annotations

import heapq
import math
from collections.abc import Callable, Iterable, Iterator
from typing import TypeVar

__all__ = ["merge_in_time"]

T = TypeVar("T")


class _Input:
    """One input's iterator, its look-ahead and the state of its continuous key."""

    def __init__(self, items: Iterator, time_of: Callable, jump_back: float, max_lead: float):
        self.items, self.time_of = items, time_of
        self.jump_back, self.max_lead = jump_back, max_lead
        self.ahead: list = []
        self.last_t: float | None = None
        self.key = 0.0
        self.offset = 0.0  # key - time: changes at discontinuities only
        self.step = 0.0
        self.before: tuple[float, float] | None = None  # (time, offset) before the last jump

    def _fill(self, n: int) -> None:
        while len(self.ahead) < n:
            item = next(self.items, _END)
            if item is _END:
                return
            self.ahead.append(item)

    def _ordinary(self, d: float) -> bool:
        return -self.jump_back <= d <= self.max_lead

    def next(self) -> tuple[float, object] | None:
        """(key, item) of the next item, or None at the end."""
        self._fill(3 if self.last_t is None else 1)
        if not self.ahead:
            return None
        item = self.ahead.pop(0)
        t = self.time_of(item)
        if not math.isfinite(t):
            return (self.key if self.last_t is not None else -math.inf), item
        if self.last_t is None:
            self.key = t
            times = [self.time_of(a) for a in self.ahead]
            if len(times) == 2 and all(map(math.isfinite, times)) and \
                    not self._ordinary(times[0] - t) and self._ordinary(times[1] - times[0]):
                self.key = times[0]  # the first item is the odd one out: anchor on the next
                self.last_t = times[0]
                return self.key, item
        else:
            d = t - self.last_t
            if self._ordinary(d):
                self.key = t + self.offset
                if d > 0:
                    self.step = d
            elif self.before is not None and self._ordinary(t - self.before[0]):
                self.offset = self.before[1]  # back where it was: the jump was one bad time
                self.before = None
                self.key = t + self.offset
            else:
                self.before = (self.last_t, self.offset)
                self.key += self.step
                self.offset = self.key - t
        self.last_t = t
        return self.key, item


_END = object()


def merge_in_time(inputs: Iterable[Iterable[T]], *, time_of: Callable[[T], float],
                  jump_back: float, max_lead: float) -> Iterator[T]:
    """Items of every input, merged by each input's continuous time key.

    ``time_of(item)`` is an item's time [s]; ``jump_back`` and ``max_lead`` [s] are the
    steps back and forward beyond which an input's time is taken to have jumped (the
    timeline's ``clock_jump`` and ``max_lead``). Ties go to the earlier input. Inputs
    are read lazily, at most three items ahead.
    """
    inputs = list(inputs)
    if len(inputs) == 1:  # nothing to merge
        yield from inputs[0]
        return
    heads: list[tuple[float, int, int, object, _Input]] = []
    seq = 0
    for i, items in enumerate(inputs):
        src = _Input(iter(items), time_of, jump_back, max_lead)
        head = src.next()
        if head is not None:
            heapq.heappush(heads, (head[0], i, seq, head[1], src))
            seq += 1
    while heads:
        _, i, _, item, src = heapq.heappop(heads)
        yield item  # type: ignore[misc]
        head = src.next()
        if head is not None:
            heapq.heappush(heads, (head[0], i, seq, head[1], src))
            seq += 1
