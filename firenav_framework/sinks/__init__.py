"""Built-in sinks. Each module lists its plugin classes in ``PLUGINS``."""
from __future__ import annotations

from ..hookspecs import hookimpl
from ..registry import collect_plugins


@hookimpl
def firenav_plugins() -> list[type]:
    return collect_plugins(__name__)
