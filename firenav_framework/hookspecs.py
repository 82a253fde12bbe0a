"""Hook specifications: how a package tells firenav what it provides.

A package registers under the ``firenav`` entry-point group a module (or object)
carrying pluggy hook implementations::

    # pyproject.toml of the vendor package
    [project.entry-points.firenav]
    acme_uwb = "acme_firenav.plugin"

    # acme_firenav/plugin.py
    from firenav_framework import hookimpl

    @hookimpl
    def firenav_plugins():
        return [AcmeUwbSensor]

Built-in plugins register exactly the same way.
"""
from __future__ import annotations

import pluggy

PROJECT = "firenav"
hookspec = pluggy.HookspecMarker(PROJECT)
hookimpl = pluggy.HookimplMarker(PROJECT)


@hookspec
def firenav_plugins() -> list[type]:
    """Return the component classes (sources, sensors, estimators, constraints,
    sinks) this package provides. Each must subclass one of the bases in
    :mod:`firenav_framework.components` and set a unique ``name``."""
