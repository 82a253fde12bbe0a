"""The ``wall_follow`` constraint: a straight run beside a wall is turned parallel to it."""
from .constraint import WallFollowConstraint

__all__ = ["WallFollowConstraint"]
