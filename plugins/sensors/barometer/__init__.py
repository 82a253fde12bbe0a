"""Barometer worn by a firefighter: static pressure to height in the building's z.

Inputs: ``RawFrame`` s of a serial or UDP link, decoded by the codec ``frames.codecs``
names for the transport (by default ``baro_lines``: ``BARO,<device>,<Pa>[,<degC>]``,
``*HH`` optional). One barometer, ``reference`` (``base/baro`` by default), stands at
the entrance or the base station; every other one is worn, named ``<agent>/<device>``
(or mapped with ``devices``).

Each worn barometer is **zeroed** over its first ``calibrate_s`` seconds (the wearer at
the entrance level, as for the INS alignment): the mean difference to the reference
then removes the two sensors' offsets and their height difference, and the reference
follows the weather from then on (:mod:`.height`). Heights are published at most every
``period`` seconds per firefighter (the mean of the readings in between) as
:class:`~firenav_framework.messages.PressureHeight` on port ``height``, in the building's
z (``zero_level`` plus the height above it), with a 1-sigma ``sigma`` from the reading
noise, the zeroing, the reference, its age (weather drift) and ``indoor_offset`` (what
zeroing cannot remove: fire, doors, ventilation). Without a reference the zeroing
pressure stands in for it and the drift grows the uncertainty with time.

Bad data: broken lines (``bad_frames``, ``checksum_errors``), readings out of time
order (per device) and readings of an unknown barometer are counted and reported
(rate-limited), never raised; other lines on the link are counted and skipped.
The message contract for estimators fusing height is ``docs/barometer.md``.
"""
from .sensor import BarometerSensor

__all__ = ["BarometerSensor"]
