"""Built-in constraints, one package per plugin (registered under the ``firenav.plugins``
entry-point group in pyproject.toml).

* ``orca``, ``wall_follow``, ``anchor_range``: odometry corrections for ``dead_reckoning``
  (ORCA map-matching paper, docs/orca.md);
* ``wall_crossing``, ``search_pattern_icp``: particle constraints for ``particle_filter``
  (search-pattern paper, docs/particle-filter.md).

Shared by more than one of them, owned by none: :mod:`.anchor_ranges` (the building's UWB
anchors and the screen of ranges to them) and :mod:`.turn_history` (how much a walker
turned over its last two steps).
"""
