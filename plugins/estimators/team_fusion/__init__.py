"""Team fusion of the single-method estimators: the ``team_fusion`` estimator.

Modules: :mod:`.estimator` (the plugin: carrying, gating, fusing, floor vote,
integrity), :mod:`.fusion` (covariance intersection, the consistency gate, rival
hypotheses), :mod:`.trail` (the odometry inputs are carried along), :mod:`.params`.
"""
from .estimator import TeamFusionEstimator
from .params import TeamFusionParams

__all__ = ["TeamFusionEstimator", "TeamFusionParams"]
