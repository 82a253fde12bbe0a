"""firenav: plugin-based sensor fusion that locates firefighters inside buildings.

The public API for plugin authors is re-exported here: the role bases and parameter
helpers of :mod:`firenav_framework.contract`, the message types of
:mod:`firenav_framework.messages` and the ``hookimpl`` marker.
"""
from .contract import (AgentPose, Angle, AngularRate, Component, Constraint, Context,
                       Estimator, FileSink, Params, PerAgent, Sensor, Sink, Source, StartPose,
                       Vec3, hookimpl, param)
from .messages import (BreadcrumbDrop, Diagnostic, GroundTruth, ImuBlock, Message, Odometry,
                       PoseEstimate, Range, RawFrame, RssiReading, TagDeployment, TagDetection,
                       Tick)

__version__ = "0.1.0"

__all__ = [
    "AgentPose", "Angle", "AngularRate", "Component", "Constraint", "Context", "Estimator",
    "FileSink", "Params", "PerAgent", "Sensor", "Sink", "Source", "StartPose", "Vec3",
    "hookimpl", "param", "BreadcrumbDrop", "Diagnostic", "GroundTruth", "ImuBlock", "Message",
    "Odometry", "PoseEstimate", "Range", "RawFrame", "RssiReading", "TagDeployment",
    "TagDetection", "Tick", "__version__",
]
