"""The record of the UWB codecs: one two-way-ranging report of a DW1000-style tag."""
from __future__ import annotations

from typing import NamedTuple

__all__ = ["TwrReport"]


class TwrReport(NamedTuple):
    """One two-way-ranging exchange between a tag and an anchor, as the tag reported it.

    ``t`` [s] the frame's time (the reports carry no clock of their own); ``tag`` and
    ``anchor`` as the device names them (numbers or names); ``range_m`` the raw range
    [m], antenna delay applied, no bias correction (None: the exchange failed);
    ``rx_dbm``/``fp_dbm`` total and first-path received power [dBm] (None when not
    reported); ``seq`` the tag's report counter 0-255 (None when not reported).
    """

    t: float
    tag: str
    anchor: str
    range_m: float | None
    rx_dbm: float | None = None
    fp_dbm: float | None = None
    seq: int | None = None
