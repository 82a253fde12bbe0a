"""ORCA collision-avoidance velocity map matching (the ORCA map-matching paper, §2.2).

``constraint`` holds the plugin and the paper's rules; ``step_solver`` the per-step
collision check and ORCA solve over the floor's wall grid; ``velocity_obstacles`` the
ORCA half-planes and linear programs; ``doors`` the missed-door rule's choice of door
by UWB range.
"""
from .constraint import OrcaConstraint, approach_angle, classify_rotation, line_crossing

__all__ = ["OrcaConstraint", "classify_rotation", "approach_angle", "line_crossing"]

PLUGINS = [OrcaConstraint]
