"""The ``orca`` constraint: ORCA collision-avoidance velocity map matching (ORCA paper §2.2).

``constraint`` holds the plugin; ``rules`` the paper's reading of a wall contact;
``step_solver`` the per-step collision check and ORCA solve over the floor's walls;
``velocity_obstacles`` the ORCA half-planes and linear programs; ``doors`` the
missed-door rule's choice of door by UWB range.
"""
from .constraint import OrcaConstraint

__all__ = ["OrcaConstraint"]
