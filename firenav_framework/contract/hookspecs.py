"""Hook specifications: what a package's hook module can tell firenav.

A package registers, under the ``firenav`` entry-point group, a module carrying pluggy
hook implementations::

    # pyproject.toml of the vendor package
    [project.entry-points.firenav]
    acme = "acme_firenav.plugin"

    # acme_firenav/plugin.py
    from firenav_framework import hookimpl

    @hookimpl
    def firenav_plugins():
        return [AcmeImu]

(A package may instead list each class under ``firenav.plugins``; see
:mod:`firenav_framework.registry`. Codecs register under ``firenav.codecs``; see
:mod:`firenav_framework.codecs`.) Hook calls take keyword arguments only; a misspelled
hook name is reported, not ignored.
"""
from __future__ import annotations

import pluggy

from .component import Component

PROJECT = "firenav"
hookspec = pluggy.HookspecMarker(PROJECT)
hookimpl = pluggy.HookimplMarker(PROJECT)


@hookspec
def firenav_plugins() -> list[type[Component]]:
    """Return the component classes (sources, sensors, estimators, constraints, sinks)
    this package provides. Each must subclass one of the role bases of
    :mod:`firenav_framework.contract`, implement its abstract hooks and set a unique
    ``name``."""
