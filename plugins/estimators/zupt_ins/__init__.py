"""ZUPT-aided INS for foot-mounted IMUs: the ``zupt_ins`` estimator and its array core.

Modules: :mod:`.rotation` (quaternions), :mod:`.detectors` (zero-velocity detectors),
:mod:`.eskf` (strapdown + error-state Kalman filter), :mod:`.engine` (the streaming
core used by the estimator and the benchmarks), :mod:`.steps` (step odometry and gait
labels), :mod:`.retro` (zupt-extension swing correction), :mod:`.metrics` (the real
datasets' error measures), :mod:`.params`, :mod:`.estimator` (the plugin).
"""
from .engine import BlockResult, InsEngine
from .estimator import ZuptInsEstimator
from .params import ZuptInsParams

__all__ = ["BlockResult", "InsEngine", "ZuptInsEstimator", "ZuptInsParams"]
