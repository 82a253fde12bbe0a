"""firenav: plugin-based sensor fusion that locates firefighters inside buildings.

The public API for plugin authors is re-exported here: the component bases, the
``param`` helper, message types and the ``hookimpl`` marker.
"""
from .components import (Component, Constraint, Context, Estimator, Params, PerAgent, Sensor,
                         Sink, Source, param)
from .hookspecs import hookimpl
from .messages import (BreadcrumbDrop, Diagnostic, GroundTruth, ImuBlock, Message, Odometry,
                       PoseEstimate, Range, RawFrame, RssiReading, TagDeployment, TagDetection,
                       Tick)

__version__ = "0.1.0"

__all__ = [
    "Component", "Constraint", "Context", "Estimator", "Params", "PerAgent", "Sensor", "Sink",
    "Source", "param", "hookimpl", "BreadcrumbDrop", "Diagnostic", "GroundTruth", "ImuBlock",
    "Message", "Odometry", "PoseEstimate", "Range", "RawFrame", "RssiReading", "TagDeployment",
    "TagDetection", "Tick", "__version__",
]
