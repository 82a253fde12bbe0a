"""ZUPT-aided INS for foot-mounted IMUs: the ``zupt_ins`` estimator and its array core.

Modules: :mod:`.rotation` (quaternions), :mod:`.detectors` (zero-velocity detectors),
:mod:`.eskf` (strapdown + error-state Kalman filter), :mod:`.engine` (the streaming
core used by the plugin, the simulator and the benchmarks), :mod:`.steps` (step
odometry and gait labels), :mod:`.retro` (zupt-extension swing correction),
:mod:`.metrics` (the real datasets' error measures), :mod:`.params`, :mod:`.plugin`.
"""
from .engine import BlockResult, InsEngine
from .params import ZuptInsParams
from .plugin import ZuptIns

__all__ = ["BlockResult", "InsEngine", "ZuptIns", "ZuptInsParams"]

PLUGINS = [ZuptIns]
