"""Testing firenav plugins: a harness that runs one plugin without a pipeline, sample
input of every message type, and the conformance suite a plugin author runs in one call.

>>> from firenav_framework.testing import check_plugin, run_component
>>> check_plugin(MySensor)                                    # every conformance check
>>> published = run_component(MySensor, {"gain": 2.0}, [("in", some_message)])

==================  ===========================================================================
module              what it holds
==================  ===========================================================================
``harness``         :class:`Session`, :func:`make_component`, :func:`run_component`: one
                    plugin fed like the runner feeds it (ticks, a constraint's host)
``samples``         :func:`sample_world`: a short simulated team run with every message
                    type and its building, the default input of the checks
``checks``          the individual checks (:data:`CHECKS`), each usable on its own
``suite``           :func:`check_plugin` (all checks over one class) and :func:`run_checks`
``codec_checks``    :func:`check_codec`: the same for a wire codec
==================  ===========================================================================

Fill-in templates for each kind, which pass :func:`check_plugin` as they are, are in
``extension_templates/`` of the firenav repository.
"""
from .checks import CHECKS, CheckFailed, NotApplicable, PluginCase, parameter_problems
from .codec_checks import CODEC_CHECKS, CodecCase, check_codec, run_codec_checks
from .harness import Recorder, Session, make_component, run_component, with_ticks
from .samples import SampleWorld, sample_world
from .suite import ConformanceError, check_plugin, plugin_case, run_checks

__all__ = ["CHECKS", "CheckFailed", "NotApplicable", "PluginCase", "parameter_problems",
           "CODEC_CHECKS", "CodecCase", "check_codec", "run_codec_checks", "Recorder", "Session", "make_component",
           "run_component", "with_ticks", "SampleWorld", "sample_world", "ConformanceError",
           "check_plugin", "plugin_case", "run_checks"]
