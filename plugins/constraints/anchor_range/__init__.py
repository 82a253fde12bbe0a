"""The ``anchor_range`` constraint: UWB ranges to fixed anchors correct the position."""
from .constraint import AnchorRangeConstraint

__all__ = ["AnchorRangeConstraint"]
