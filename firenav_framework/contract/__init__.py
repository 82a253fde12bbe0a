"""The plugin contract: everything a plugin author needs, one module per role.

==============  ==================================================================
module          what it says
==============  ==================================================================
``component``   what every plugin is: name, Params, inputs/outputs, lifecycle,
                time order, fault containment, immutable messages, ticks
``source``      :class:`Source`: ``messages()``, live sources, ``--input``, a
                building of its own
``sensor``      :class:`Sensor`: device data -> SI measurements, via codecs
``estimator``   :class:`Estimator`: measurements -> poses with covariance;
                ``accepts`` the constraint capabilities it calls
``constraint``  :class:`Constraint`: implements a capability of
                :mod:`firenav_framework.capabilities`
``sink``        :class:`Sink`, :class:`FileSink`: consumers; files under ``--output``
``params``      :class:`Params`, :func:`param`, SI angle types, :class:`StartPose`
``context``     :class:`Context` (publish, count, report, building, paths),
                :class:`PerAgent`
``hookspecs``   the pluggy hooks of a package's hook module
==============  ==================================================================

The flow of a message: a transport (or recording, or the simulator) yields it from a
source; the timeline (:mod:`firenav_framework.timeline`) merges every source into
measurement-time order with named rules (duplicates, late messages, clock jumps,
gaps) and interleaves ticks; the bus (:mod:`firenav_framework.bus`) delivers it to each
subscriber of its stream (``<component id>.<port>``), depth first, containing faults
per component and firefighter; sensors publish measurements, estimators poses, and
sinks write them out. Wire formats live in :mod:`firenav_framework.codecs`.

Fill-in templates for each kind are in ``extension_templates/``;
:func:`firenav_framework.testing.check_plugin` is the conformance check.
"""
from .component import Component
from .constraint import Constraint
from .context import Context, NoBuilding, PerAgent, pipeline_dir
from .estimator import Estimator
from .hookspecs import hookimpl
from .kinds import KIND_BASES, KINDS
from .params import AgentPose, Angle, AngularRate, Params, StartPose, Vec3, param
from .sensor import Sensor
from .sink import FileSink, OutputName, OutputPathError, Sink
from .source import Source

__all__ = ["Component", "Constraint", "Context", "NoBuilding", "PerAgent", "pipeline_dir",
           "Estimator", "hookimpl", "KIND_BASES", "KINDS", "AgentPose", "Angle",
           "AngularRate", "Params", "StartPose", "Vec3", "param", "Sensor", "FileSink",
           "OutputName", "OutputPathError", "Sink", "Source"]
