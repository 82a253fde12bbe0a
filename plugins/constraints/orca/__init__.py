"""ORCA collision-avoidance velocity map matching (the ORCA map-matching paper, §2.2).

``constraint`` holds the plugin and the paper's rules; ``step_solver`` the per-step
collision check and ORCA solve over the floor's wall grid; ``velocity_obstacles`` the
ORCA half-planes and linear programs; ``doors`` the missed-door rule's choice of door
by UWB range; ``turns`` the turn detection the guards share.

Two companion constraints correct what ORCA cannot see: ``wall_follow`` (a straight
run alongside a wall is made parallel to it: heading drift away from a wall) and
``ranging`` (``anchor_range``: UWB ranges to the anchors correct the position, the
paper's §5 outlook: stride-length error along a corridor).
"""
from .constraint import OrcaConstraint, approach_angle, classify_rotation, line_crossing
from .ranging import AnchorRangeConstraint
from .wall_follow import WallFollowConstraint

__all__ = ["OrcaConstraint", "WallFollowConstraint", "AnchorRangeConstraint", "classify_rotation",
           "approach_angle", "line_crossing"]

PLUGINS = [OrcaConstraint, WallFollowConstraint, AnchorRangeConstraint]
