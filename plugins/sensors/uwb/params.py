"""Parameters of the ``uwb`` sensor, in groups: frames, NLOS suspicion, outlier gate."""
from __future__ import annotations

from typing import ClassVar

from firenav_framework.codecs.selection import CodecSelection
from firenav_framework.codecs.twr_report import TwrReport
from firenav_framework.contract import Params, param

from .bias import AnchorBias

__all__ = ["UwbParams", "Frames", "NlosRules", "Gate"]


class Frames(CodecSelection):
    """Codecs of the RawFrame inputs, per link transport."""

    record: ClassVar[type] = TwrReport

    codecs: dict[str, str] = param({"can": "uwb_can", "serial": "uwb_lines", "udp": "uwb_lines"})
    """link transport -> codec decoding its reports (docs/formats/uwb.md)"""


class NlosRules(Params):
    """When a range is suspected non-line-of-sight, and what sigma it then gets."""

    sigma: float = param(0.5, unit="m", gt=0)
    """1-sigma of an NLOS-suspect range"""
    power_gap: float = param(6.0, unit="dB", gt=0)
    """total minus first-path power above which a range is NLOS-suspect"""
    innovation: float | None = param(3.0, gt=0)
    """a range longer than its link's smoothed track predicts by this many sigmas is NLOS-suspect
    (null: off)"""
    range_accel: float = param(0.5, unit="m/s^2", gt=0)
    """range acceleration the track allows (walking, turning)"""


class Gate(Params):
    """Which ranges are dropped: implausible values and jumps faster than walking."""

    min_range: float = param(0.0, unit="m", ge=0)
    """ranges below this are dropped"""
    max_range: float = param(150.0, unit="m", gt=0)
    """ranges above this are dropped"""
    max_speed: float = param(6.0, unit="m/s", gt=0)
    """fastest a range can change: a firefighter running (3-4 m/s, faster in strides) with margin,
    since the sensor sees no odometry"""
    sigmas: float = param(5.0, gt=0)
    """outlier gate beyond the motion bound, in range sigmas"""
    relock_after: int = param(3, ge=1)
    """mutually consistent rejected ranges after which the link accepts them (re-locks)"""


class UwbParams(Params):
    """Parameters of the ``uwb`` sensor."""

    tags: dict[str, str] = param({})
    """tag number/name in the frames -> firefighter id (default 'tag<n>')"""
    anchors: dict[str, str] = param({})
    """anchor number/name in the frames -> building anchor id (default 'anchor<n>')"""
    bias: dict[str, AnchorBias] = param({})
    """bias model per anchor id ('*' for every anchor without its own)"""
    sigma: float = param(0.10, unit="m", gt=0)
    """1-sigma of a line-of-sight range (DW1000 TWR: about 0.1 m)"""
    nlos: NlosRules = param(NlosRules())
    """NLOS suspicion (power gap, range track) and the sigma of a suspect range"""
    gate: Gate = param(Gate())
    """range limits and the motion-bounded outlier gate"""
    silence_timeout: float = param(3.0, unit="s", gt=0)
    """a link with no range for this long raises a uwb_silent warning"""
    frames: Frames = param(Frames())
    """RawFrame inputs: the codec per transport and its options (e.g. a DBC for uwb_can)"""
