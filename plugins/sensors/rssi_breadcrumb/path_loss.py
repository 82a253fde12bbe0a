"""The log-distance path-loss model, ``RSSI = P_1m - 10 n log10(d) + X``, inverted."""
from __future__ import annotations

import math

__all__ = ["rssi_to_range", "range_sigma"]

LN10 = math.log(10.0)


def rssi_to_range(rssi_dbm: float, rssi_1m_dbm: float, exponent: float) -> float:
    """Range [m] of the log-distance path-loss model for an RSSI [dBm]."""
    return 10.0 ** ((rssi_1m_dbm - rssi_dbm) / (10.0 * exponent))


def range_sigma(range_m: float, shadowing_db: float, exponent: float) -> float:
    """Standard deviation [m] of a model range: ``d sigma_dB ln(10) / (10 n)``."""
    return range_m * shadowing_db * LN10 / (10.0 * exponent)
