"""Plugin discovery: entry points of the ``firenav`` group, loaded through pluggy.

Each entry point is loaded in its own ``try`` so that one broken third-party package
is reported and skipped instead of stopping every other plugin from loading (pluggy's
``load_setuptools_entrypoints`` aborts on the first failure). ``check_pending`` then
catches misspelled hook names.
"""
from __future__ import annotations

import functools
import importlib.metadata as md
import logging
from dataclasses import dataclass, field

import pluggy
from pydantic import BaseModel

from . import hookspecs
from .components import KINDS, Component

log = logging.getLogger("firenav.registry")

ENTRY_POINT_GROUP = "firenav"


@dataclass(frozen=True)
class PluginInfo:
    """One installed plugin class and where it came from."""

    name: str
    kind: str
    cls: type[Component]
    package: str
    version: str

    @property
    def summary(self) -> str:
        return self.cls.summary()


@dataclass
class Registry:
    """All known plugins by kind and name, plus the problems met while loading them."""

    plugins: dict[tuple[str, str], PluginInfo] = field(default_factory=dict)
    errors: list[str] = field(default_factory=list)

    def add(self, cls: type, *, package: str = "", version: str = "") -> None:
        """Register one component class, recording (not raising) anything wrong with it."""
        problem = _check_plugin_class(cls)
        if problem:
            self.errors.append(f"{package or '?'}: {problem}")
            return
        key = (cls.kind, cls.name)
        if key in self.plugins:
            first = self.plugins[key]
            self.errors.append(
                f"{package}: {cls.kind} plugin '{cls.name}' is already provided by "
                f"{first.package}; keeping that one")
            return
        self.plugins[key] = PluginInfo(cls.name, cls.kind, cls, package, version)

    def get(self, kind: str, name: str) -> PluginInfo | None:
        return self.plugins.get((kind, name))

    def names(self, kind: str | None = None) -> list[str]:
        return sorted(n for k, n in self.plugins if kind is None or k == kind)

    def find(self, name: str) -> list[PluginInfo]:
        """Every plugin called ``name``, whatever its kind."""
        return [p for (k, n), p in sorted(self.plugins.items()) if n == name]

    def by_kind(self) -> dict[str, list[PluginInfo]]:
        out: dict[str, list[PluginInfo]] = {k: [] for k in KINDS}
        for (kind, _), info in sorted(self.plugins.items()):
            out[kind].append(info)
        return out


def _check_plugin_class(cls: object) -> str | None:
    if not isinstance(cls, type) or not issubclass(cls, Component):
        return f"{cls!r} is not a firenav component class"
    if cls.kind not in KINDS:
        return f"{cls.__name__} has kind {cls.kind!r}; expected one of {', '.join(KINDS)}"
    if not cls.name or not cls.name.replace("_", "").replace("-", "").isalnum():
        return f"{cls.__name__} needs a `name` made of letters, digits, '_' or '-'"
    if not (isinstance(cls.Params, type) and issubclass(cls.Params, BaseModel)):
        return f"{cls.__name__}.Params must be a pydantic model"
    return None


def _dist_of(ep: md.EntryPoint) -> tuple[str, str]:
    dist = getattr(ep, "dist", None)
    if dist is None:
        return ep.value.split(":")[0].split(".")[0], ""
    return dist.metadata["Name"], dist.version


def load_registry(entry_points: list[md.EntryPoint] | None = None) -> Registry:
    """Discover plugins from entry points (all of the ``firenav`` group by default)."""
    registry = Registry()
    pm = pluggy.PluginManager(hookspecs.PROJECT)
    pm.add_hookspecs(hookspecs)
    if entry_points is None:
        entry_points = sorted(md.entry_points(group=ENTRY_POINT_GROUP),
                              key=lambda e: (e.dist.metadata["Name"] != "firenav"
                                             if e.dist else True, e.name))
    origin: dict[str, tuple[str, str]] = {}
    for ep in entry_points:
        package, version = _dist_of(ep)
        try:
            module = ep.load()
            pm.register(module, name=f"{package}:{ep.name}")
        except Exception as exc:  # a broken third-party plugin must not stop the rest
            registry.errors.append(
                f"{package}: entry point '{ep.name} = {ep.value}' failed to load: "
                f"{type(exc).__name__}: {exc}")
            log.warning("skipping plugin %s: %s", ep.name, exc)
            continue
        origin[f"{package}:{ep.name}"] = (package, version)
    while True:  # a misspelled hook would otherwise be ignored silently
        try:
            pm.check_pending()
            break
        except pluggy.PluginValidationError as exc:
            name = pm.get_name(exc.plugin) if exc.plugin is not None else "?"
            registry.errors.append(f"{origin.get(name, (name,))[0]}: {exc}")
            if exc.plugin is None:
                break
            origin.pop(name, None)
            pm.unregister(exc.plugin)
    for impl in reversed(pm.hook.firenav_plugins.get_hookimpls()):
        package, version = origin.get(impl.plugin_name, (impl.plugin_name, ""))
        try:
            classes = impl.function()
        except Exception as exc:
            registry.errors.append(f"{package}: firenav_plugins() raised "
                                   f"{type(exc).__name__}: {exc}")
            continue
        for cls in classes or ():
            registry.add(cls, package=package, version=version)
    registry.errors.extend(_IMPORT_ERRORS)
    _IMPORT_ERRORS.clear()
    return registry


@functools.lru_cache(maxsize=1)
def default_registry() -> Registry:
    """The registry of everything installed, loaded once per process."""
    return load_registry()


def collect_plugins(package: str) -> list[type]:
    """Component classes listed in ``PLUGINS`` of every module of ``package``.

    The built-in packages use this in their ``firenav_plugins`` hook, so each plugin
    module declares its own plugins and no shared list has to be edited. A module
    that fails to import is logged and skipped, like a broken third-party package.
    """
    import importlib
    import pkgutil

    pkg = importlib.import_module(package)
    found: list[type] = list(getattr(pkg, "PLUGINS", []))
    for mod in sorted(pkgutil.iter_modules(pkg.__path__), key=lambda m: m.name):
        if mod.name.startswith("_"):
            continue
        try:
            module = importlib.import_module(f"{package}.{mod.name}")
        except Exception as exc:
            problem = f"{package}.{mod.name} failed to import: {type(exc).__name__}: {exc}"
            log.error("%s", problem)
            _IMPORT_ERRORS.append(problem)
            continue
        found.extend(getattr(module, "PLUGINS", []))
    return found


#: Import failures of built-in plugin modules, reported with the registry's errors.
_IMPORT_ERRORS: list[str] = []
