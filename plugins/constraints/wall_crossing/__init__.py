"""The ``wall_crossing`` constraint: particles may not walk through walls."""
from .constraint import WallCrossingConstraint

__all__ = ["WallCrossingConstraint"]
