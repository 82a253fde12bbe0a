"""The ``search_pattern_icp`` constraint: search-pattern ICP pseudo-observations for the
particle filter (search-pattern paper §IV-D/E).

Modules: :mod:`.principal` (eq. 1), :mod:`.icp` (batched ICP), :mod:`.comparison`
(Algorithm 1 and the association of eq. 2), :mod:`.constraint` (the plugin).
"""
from .constraint import SearchPatternIcpConstraint

__all__ = ["SearchPatternIcpConstraint"]
