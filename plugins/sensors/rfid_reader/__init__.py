"""RFID reader worn by a firefighter: tag reads debounced into one detection per pass.

The RFID/MEMS paper (rfid-mems-ekf, "RFID and Database") has the first team stick a tag
on each door jamb (and at both ends of each stair) and every agent's reader correct the
position when it passes a tag. A reader reports a tag many times while it is in range
(several read attempts a second), so this sensor merges the reads of one tag by one
reader into a **pass**: reads closer than ``pass_gap`` seconds belong together, and a
pass ends ``pass_gap`` after its last read (or after ``max_pass`` seconds, for an agent
standing at a tag). A pass becomes one :class:`TagDetection` whose time is that of the
**strongest read** (the reader is nearest the tag then), with the total read count and
that peak RSSI. The sensor needs time to pass to close a pass: it ticks every
``flush_period`` seconds.

Inputs: ``TagDetection`` (raw or window-aggregated reads, e.g. the simulator's),
``TagDeployment`` (the dispenser's "tag attached" events) and ``RawFrame`` s of a
serial or UDP link, decoded by the codec ``frames.codecs`` names for the transport (by
default ``rfid_lines``: one line per read or deployment; ``*HH`` optional, the XOR of
the bytes before ``*`` in hex, as NMEA)::

    TAG,<reader>,<tag_id>,<rssi_dbm>[,<reads>]     a read; rssi may be empty
    DEPLOY,<reader>,<tag_id>                       the wearer attached this tag

``reader`` is the device id ``<agent>/<device>`` (``ff1/rfid``) unless ``readers`` maps
it to an agent. Other lines on the link are counted and skipped; broken ones are
counted and reported once.

Bad data is never fatal: a read of a tag no one deployed (and not in ``known_tags``) is
passed on, counted (``unknown_tag_reads``) and reported once per firefighter and tag; a second
deployment of an id already deployed is a **duplicate tag id**: counted, reported, and
dropped (the first placement stands).
"""
from .sensor import RfidReaderSensor

__all__ = ["RfidReaderSensor"]
