"""RSSI breadcrumb radio: ranges from a path-loss model, encounters, moved breadcrumbs.

Breadcrumb radios (2.4 GHz, breadcrumb paper §III, §V) report the RSSI of every packet
heard from another node: the base station, a dropped breadcrumb or a firefighter's
radio (node id = the agent id). This sensor turns that traffic into measurements for a
relative measurement graph:

* ``range`` - every plausible reading as a :class:`Range` (``method="rssi"``) through the
  log-distance model (:mod:`.path_loss`) ``RSSI = P_1m - 10 n log10(d) + X``,
  ``X ~ N(0, sigma_dB^2)``, inverted as ``d = 10^((P_1m - RSSI) / (10 n))``. Its standard deviation grows with the
  range (delta method on the log): ``sigma_d = d sigma_dB ln(10) / (10 n)``.
* ``encounters`` - a firefighter passing a node (§V-A: the RSSI rises above about -40 dBm,
  i.e. within about a metre; "points with local optimum are considered as the positions
  where encounters occur"). One encounter per episode above ``encounter.dbm``, at the
  episode's peak, published once the RSSI has fallen ``encounter.hysteresis_db`` below
  the peak (or the link went quiet; :mod:`.encounters`). Message: :class:`Range` with
  ``method="rssi_encounter"``, ``t`` the peak time, ``range_m`` the model range at the
  peak and ``sigma_m`` = ``encounter.sigma_m`` (the estimator reads it as "the two nodes
  were at the same place, within sigma_m per axis").
* ``moved`` - a breadcrumb that was kicked (§V-C: moved 1-2 m). The links between fixed
  nodes (breadcrumbs, base station) keep a steady RSSI; when the median of a node's
  links to at least ``kick.min_links`` other fixed nodes shifts by more than ``kick.db``
  while those nodes' other links stay put, the node has moved (:mod:`.kicks`).
  Published as a
  :class:`BreadcrumbDrop` of the already-dropped node id (``agent`` empty, ``device``
  ``"kick_detector"``) at the time the change began: "this node was placed anew".
* ``drops`` - every breadcrumb drop the sensor took in, once per node id (for the
  estimators that place breadcrumbs where they were dropped).

Inputs: ``RssiReading`` and ``BreadcrumbDrop`` messages (the simulator's), and
``RawFrame`` s of a serial or UDP link decoded by the codec ``frames.codecs`` names for
the transport (by default ``breadcrumb_lines``, docs/formats/breadcrumb-radio.md:
``RSSI,<receiver>,<transmitter>,<dBm>`` and ``DROP,<agent>/dispenser,<node>``). Other
devices' lines are counted (``other_lines``), broken ones counted and reported once.

Impossible readings are counted and skipped, never passed on: RSSI above
``max_rssi_dbm`` (0 dBm: no receiver reads more than a transmitter sends at 2.4 GHz
short range) or below ``min_rssi_dbm``, non-finite values, a node hearing itself,
unknown node ids and breadcrumbs that have not been dropped yet (still in the dispenser).
A reading older than its link's last one (out of time order) is dropped, counted as
``out_of_order`` and warned once per link: the encounter peaks and kick medians follow
each link forward in time.
"""
from .path_loss import range_sigma, rssi_to_range
from .sensor import RssiBreadcrumbSensor

__all__ = ["RssiBreadcrumbSensor", "range_sigma", "rssi_to_range"]
