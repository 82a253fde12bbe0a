"""Dead reckoning in the building frame: the ``dead_reckoning`` estimator.

Modules: :mod:`.estimator` (the plugin: alignment, integration, corrections, outputs),
:mod:`.alignment` (IMU-yaw offset, first straight segment, true start pose),
:mod:`.params`.
"""
from .estimator import DeadReckoningEstimator
from .params import DeadReckoningParams, DeadReckoningStart

__all__ = ["DeadReckoningEstimator", "DeadReckoningParams", "DeadReckoningStart"]
