"""UWB two-way ranging between a wearable tag and fixed anchors (DW1000-style devices).

The ORCA map-matching paper (§3.1) leaves a UWB anchor at the entrance and ranges to a
DW1000 tag on the firefighter; its missed-door rule picks the door that fits that
range. This sensor turns the device reports into clean :class:`Range` messages:

* **decoding** of the link's reports with the codec ``frames.codecs`` names for its
  transport (``docs/formats/uwb.md``): by default the serial/UDP text line
  ``RANGE,<tag>,<anchor>,<range_mm>,<rx_power_dbm>,<fp_power_dbm>[,<seq>][*<xor>]``
  (``uwb_lines``) and the CAN frame ``UWB_TWR_REPORT`` of ``uwb_twr.dbc`` (``uwb_can``).
  Already-decoded ``Range`` messages (the simulator's) pass through the same chain.
* **bias calibration** per anchor (:mod:`.bias`):
  ``measured = scale * true + offset + b(rx_power)`` with ``b`` a piecewise-linear table
  over received power (the DW1000's range bias grows as the signal weakens).
* **NLOS suspicion**: a total received power more than ``nlos.power_gap`` (6 dB) above
  the first-path power means most energy arrived late, i.e. the direct path is
  blocked (the usual DW1000 rule of thumb, Decawave APS006); without power readings
  (the simulator's ranges), a range longer than the link's smoothed range track
  (constant-velocity Kalman filter, :mod:`.link`) predicts by ``nlos.innovation``
  sigmas is suspect too. Such ranges are flagged ``nlos`` and get ``nlos.sigma``.
* **outliers**: a range that moved farther from the link's last accepted range than
  walking at ``gate.max_speed`` (plus ``gate.sigmas`` sigma) allows is dropped and
  counted; after ``gate.relock_after`` mutually consistent rejects the link re-locks.
* **dropouts**: ranging failures and lost reports (sequence gaps) are counted; a link
  silent for ``silence_timeout`` raises a ``uwb_silent`` warning, cleared when it
  comes back.

Node ids: the output ``Range`` has ``a`` = the firefighter (the tag's agent id; the
tag ``n`` is mapped by ``tags``, else named ``tag<n>``), ``b`` = the anchor (mapped
by ``anchors``, else named ``anchor<n>``); ``agent`` the firefighter, ``device``
``<agent>/uwb``. Already-decoded ranges are read the same way (``a`` tag, ``b`` anchor).
"""
from .sensor import UwbSensor

__all__ = ["UwbSensor"]
