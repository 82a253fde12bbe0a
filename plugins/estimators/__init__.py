"""Built-in estimators plugins. Each module lists its plugin classes in ``PLUGINS``."""
from __future__ import annotations

from firenav_framework.hookspecs import hookimpl
from firenav_framework.registry import collect_plugins


@hookimpl
def firenav_plugins() -> list[type]:
    return collect_plugins(__name__)
