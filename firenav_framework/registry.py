"""Plugin discovery: what is installed, loaded only when it is needed.

Two entry-point groups register plugins (built-in ones use the first, exactly as a
vendor package can):

``firenav.plugins``
    One entry per plugin class, named ``<kind>.<name>``::

        [project.entry-points."firenav.plugins"]
        "sensor.acme_imu" = "acme_firenav.plugin:AcmeImu"

    The class is imported only when a pipeline (or ``plugins show``) names it, so a
    run pays for the plugins it uses and a broken package costs only its own plugins.
``firenav``
    A module carrying pluggy hook implementations (:mod:`.contract.hookspecs`); every
    such module is imported when the registry is loaded. ``check_pending`` catches
    misspelled hooks.

Every import is contained (:mod:`firenav_framework.safe_import`): a package that
fails (any exception, ``SystemExit`` or ``KeyboardInterrupt`` included) or hangs at
import (``$FIRENAV_IMPORT_TIMEOUT``, 30 s; firenav's own modules are not timed) is
reported by ``firenav plugins list`` and ``firenav validate`` and skipped; the other
plugins still load.

Names are protected: the first registration of a (kind, name) is the plugin that name
means, and built-ins register first. Another package offering the same name is never
used instead, and never imported for it: it is listed as an *offer*, ``validate`` and
``run`` warn about it where a pipeline uses that name, and a pipeline that wants it says
so explicitly by pinning the package: ``plugin: zupt_ins@acme-firenav``.
"""
from __future__ import annotations

import functools
import importlib.metadata as md
import inspect
import logging
import math
import re
from dataclasses import dataclass, field

import pluggy
from pydantic import BaseModel

from .contract import hookspecs
from .contract.component import Component
from .contract.kinds import KIND_BASES, KINDS
from .safe_import import PluginImportError, call_contained, import_object

log = logging.getLogger("firenav.registry")

HOOK_GROUP = "firenav"
PLUGIN_GROUP = "firenav.plugins"
BUILTIN_DIST = "firenav"


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


@dataclass(frozen=True)
class _Lazy:
    """A ``firenav.plugins`` entry not imported yet."""

    kind: str
    name: str
    entry_point: md.EntryPoint
    package: str
    version: str


def package_key(package: str) -> str:
    """A distribution name compared the way pip does (``Acme_Firenav`` = ``acme-firenav``)."""
    return re.sub(r"[-_.]+", "-", package).lower()


def split_pin(plugin: str) -> tuple[str, str | None]:
    """``"zupt_ins@acme-firenav"`` -> ("zupt_ins", "acme-firenav"); no pin -> (name, None)."""
    name, sep, package = plugin.partition("@")
    return (name, package) if sep else (plugin, None)


@dataclass
class Registry:
    """All known plugins by kind and name, plus the problems met while loading them."""

    plugins: dict[tuple[str, str], PluginInfo] = field(default_factory=dict)
    errors: list[str] = field(default_factory=list)
    _lazy: dict[tuple[str, str], list[_Lazy]] = field(default_factory=dict)
    #: Other packages' offers of a taken name, by (kind, name): lazy refs or classes.
    _offers: dict[tuple[str, str], list[_Lazy | PluginInfo]] = field(default_factory=dict)
    _failed: dict[tuple[str, str], str] = field(default_factory=dict)

    def add(self, cls: type, *, package: str = "", version: str = "") -> None:
        """Register one component class, recording (not raising) anything wrong with it."""
        problem = plugin_class_problem(cls)
        if problem:
            self.errors.append(f"{package or '?'}: {problem}")
            return
        key = (cls.kind, cls.name)
        if key in self.plugins or self._lazy.get(key):
            first = self.plugins.get(key) or self._lazy[key][0]
            if package_key(package) == package_key(first.package):
                self.errors.append(f"{package}: {cls.kind} plugin '{cls.name}' is already "
                                   f"provided by {first.package}; keeping that one")
                return
            self._offer(key, PluginInfo(cls.name, cls.kind, cls, package, version), first)
            return
        self.plugins[key] = PluginInfo(cls.name, cls.kind, cls, package, version)

    def add_lazy(self, ep: md.EntryPoint, package: str, version: str) -> None:
        """Register a ``firenav.plugins`` entry point without importing it."""
        kind, _, name = ep.name.partition(".")
        if kind not in KINDS or not name:
            self.errors.append(f"{package}: entry point '{ep.name}' must be named "
                               f"<kind>.<name> with kind one of {', '.join(KINDS)}")
            return
        key = (kind, name)
        ref = _Lazy(kind, name, ep, package, version)
        first = self.plugins.get(key) or (self._lazy.get(key) or [None])[0]
        if first is not None and package_key(package) != package_key(first.package):
            self._offer(key, ref, first)
            return
        self._lazy.setdefault(key, []).append(ref)

    def _offer(self, key: tuple[str, str], offer: "_Lazy | PluginInfo",
               first: "_Lazy | PluginInfo") -> None:
        self._offers.setdefault(key, []).append(offer)
        self.errors.append(
            f"{offer.package}: also offers {key[0]} plugin '{key[1]}', which "
            f"{first.package} provides; not used unless a pipeline names it "
            f"'{key[1]}@{offer.package}'")

    def _load(self, key: tuple[str, str]) -> None:
        for ref in self._lazy.pop(key, []):
            cls = self._import_ref(ref)
            if cls is not None:
                self.add(cls, package=ref.package, version=ref.version)

    def _import_ref(self, ref: _Lazy) -> type | None:
        cls = _import(ref.entry_point, ref.package, self.errors)
        if cls is None:
            self._failed[(ref.kind, ref.name)] = self.errors[-1]
            return None
        if isinstance(cls, type) and issubclass(cls, Component) and \
                (cls.kind, cls.name) != (ref.kind, ref.name):
            self.errors.append(f"{ref.package}: entry point '{ref.entry_point.name}' "
                               f"loads {cls.kind} plugin '{cls.name}'")
            return None
        return cls  # type: ignore[return-value]

    def load_all(self) -> None:
        """Import every registered plugin (for listings)."""
        for key in sorted(self._lazy):
            self._load(key)

    def get(self, kind: str, name: str, package: str | None = None) -> PluginInfo | None:
        """The plugin ``name`` of ``kind``; with ``package``, that package's offer of it
        (the explicit choice of a pipeline's ``plugin: name@package``)."""
        if (kind, name) not in self.plugins:
            self._load((kind, name))
        info = self.plugins.get((kind, name))
        if package is None or (info is not None and
                               package_key(info.package) == package_key(package)):
            return info
        offers = self._offers.get((kind, name), [])
        for i, offer in enumerate(offers):
            if package_key(offer.package) != package_key(package):
                continue
            if isinstance(offer, _Lazy):
                cls = self._import_ref(offer)
                problem = None if cls is None else plugin_class_problem(cls)
                if cls is None or problem:
                    if problem:
                        self.errors.append(f"{offer.package}: {problem}")
                    del offers[i]
                    return None
                offer = offers[i] = PluginInfo(name, kind, cls, offer.package, offer.version)
            return offer
        return None

    def offered_by(self, kind: str, name: str) -> list[str]:
        """The other packages that offer ``name`` (used only when pinned)."""
        return [o.package for o in self._offers.get((kind, name), [])]

    def load_problem(self, kind: str, name: str) -> str | None:
        """Why plugin ``name`` of ``kind`` failed to load, if it did."""
        return self._failed.get((kind, name))

    def names(self, kind: str | None = None) -> list[str]:
        """Names of the registered plugins (of one kind), imported or not."""
        keys = set(self.plugins) | {k for k, refs in self._lazy.items() if refs}
        return sorted(n for k, n in keys if kind is None or k == kind)

    def find(self, name: str) -> list[PluginInfo]:
        """Every plugin called ``name``, whatever its kind."""
        for kind in KINDS:
            self.get(kind, name)
        return [p for (k, n), p in sorted(self.plugins.items()) if n == name]

    def by_kind(self) -> dict[str, list[PluginInfo]]:
        self.load_all()
        out: dict[str, list[PluginInfo]] = {k: [] for k in KINDS}
        for (kind, _), info in sorted(self.plugins.items()):
            out[kind].append(info)
        return out


def plugin_class_problem(cls: object) -> str | None:
    """Why ``cls`` is not a usable plugin class (None when it is)."""
    if not isinstance(cls, type) or not issubclass(cls, Component):
        return f"{cls!r} is not a firenav component class"
    if cls.kind not in KINDS or not issubclass(cls, KIND_BASES[cls.kind]):
        return (f"{cls.__name__} has kind {cls.kind!r}; it must subclass one of "
                f"Source, Sensor, Estimator, Constraint, Sink")
    if not cls.name or not cls.name.replace("_", "").replace("-", "").isalnum():
        return f"{cls.__name__} needs a `name` made of letters, digits, '_' or '-'"
    if not (isinstance(cls.Params, type) and issubclass(cls.Params, BaseModel)):
        return f"{cls.__name__}.Params must be a pydantic model"
    if inspect.isabstract(cls):
        missing = ", ".join(sorted(getattr(cls, "__abstractmethods__", ())))
        return f"{cls.__name__} does not implement {missing} (required of a {cls.kind})"
    if cls.kind == "constraint" and cls.capability is None:
        return (f"{cls.__name__} must subclass a capability base from "
                f"firenav_framework.capabilities (what its estimator calls)")
    if cls.kind == "constraint" and cls.hooks and not any(
            getattr(cls, h) is not getattr(cls.capability, h) for h in cls.hooks):
        return (f"{cls.__name__} implements none of {', '.join(cls.hooks)} "
                f"(the {cls.capability.__name__} methods its estimator calls)")
    if cls.kind == "constraint" and cls.inputs and \
            cls.handle is KIND_BASES["constraint"].handle:
        return f"{cls.__name__} declares inputs but does not implement handle()"
    return None


def _import(ep: md.EntryPoint, package: str, errors: list[str]) -> object | None:
    """The object an entry point names (``module`` or ``module:attr``), with every failure
    (a hang at import included) reported instead of raised. firenav's own modules are
    not timed: on a busy machine their import may take longer than a vendor's limit,
    and a command without its simulator or INS would be no use."""
    try:
        return import_object(ep.value, math.inf if package == BUILTIN_DIST else None)
    except PluginImportError as exc:
        errors.append(f"{package}: entry point '{ep.name} = {ep.value}' failed to load: "
                      f"{exc.detail}")
        log.warning("skipping plugin %s: %s", ep.value, exc.detail)
        return None


def _dist_of(ep: md.EntryPoint) -> tuple[str, str]:
    dist = getattr(ep, "dist", None)
    if dist is None:
        return ep.value.split(":")[0].split(".")[0], ""
    return dist.metadata["Name"], dist.version


def _builtin_first(ep: md.EntryPoint) -> tuple[bool, str, str]:
    package, _ = _dist_of(ep)
    return package != BUILTIN_DIST, package, ep.name


def load_registry(entry_points: list[md.EntryPoint] | None = None) -> Registry:
    """Discover plugins from entry points (both groups of every installed package by default)."""
    registry = Registry()
    if entry_points is None:
        entry_points = [*md.entry_points(group=PLUGIN_GROUP), *md.entry_points(group=HOOK_GROUP)]
    entry_points = sorted(entry_points, key=_builtin_first)
    for ep in entry_points:
        if ep.group == PLUGIN_GROUP:
            registry.add_lazy(ep, *_dist_of(ep))
    _load_hook_modules(registry, [ep for ep in entry_points if ep.group != PLUGIN_GROUP])
    return registry


def _load_hook_modules(registry: Registry, entry_points: list[md.EntryPoint]) -> None:
    pm = pluggy.PluginManager(hookspecs.PROJECT)
    pm.add_hookspecs(hookspecs)
    origin: dict[str, tuple[str, str]] = {}
    for ep in entry_points:
        package, version = _dist_of(ep)
        module = _import(ep, package, registry.errors)
        if module is None:
            continue
        try:
            pm.register(module, name=f"{package}:{ep.name}")
        except Exception as exc:
            registry.errors.append(f"{package}: entry point '{ep.name}' is not a hook module: {exc}")
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
            classes = call_contained(impl.function, f"{package}: firenav_plugins()")
        except PluginImportError as exc:
            registry.errors.append(str(exc))
            continue
        for cls in classes or ():
            registry.add(cls, package=package, version=version)


@functools.lru_cache(maxsize=1)
def default_registry() -> Registry:
    """The registry of everything installed, loaded once per process."""
    return load_registry()
