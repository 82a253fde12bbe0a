"""Live links and what keeps them honest: receive clock, link health, raw recording.

The pieces, one job each:

* :mod:`.clock`: receive times on one process-wide clock (UNIX seconds, never
  stepping, 1 us resolution) shared by every link, so frames from different links
  are ordered consistently and a recorded timestamp round-trips exactly.
* :mod:`.health`: per-device frame rate, gaps, decode errors and silence, turned into
  :class:`~firenav_framework.messages.Diagnostic` messages for the commander.
* :mod:`.recorders`: raw frames to rotating, crash-safe files in the field's native
  formats (python-can logs, MAVLink ``.tlog``, timestamped line logs).
* :mod:`.can_link`, :mod:`.mavlink_link`, :mod:`.line_links`: the transports, each
  turning what arrives into ``(receive time, native object)`` arrivals and native
  objects into :class:`~firenav_framework.messages.RawFrame` (the same conversion is
  used by the log readers, so a replay sees byte-identical frames).
* :mod:`.live_source`: the :class:`~firenav_framework.contract.Source` base that
  ties a link, its recorder and its health monitor together;
* :mod:`.player`: the other direction, IMU data played onto links as devices would.

Sources never decode payloads: wire protocols are codecs (:mod:`firenav_framework.codecs`),
used by the sensors to decode and by the player to encode.
"""
