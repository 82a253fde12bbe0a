"""Pipeline files: parsing, ``--set`` overrides and validation with file locations.

A pipeline is a YAML file::

    name: demo
    building: ../buildings/office.geojson      # optional, relative to this file
    timeline: {reorder_window: 0.25}             # optional, see TimelineConfig
    on_error: disable_agent                      # default fault policy
    sources:    [ {id: sim, plugin: simulator, scenario: ...} ]
    sensors:    [ {id: imu, plugin: foot_imu, input: sim.imu} ]
    estimators: [ {id: ins, plugin: zupt_ins, input: imu.imu,
                   constraints: [ {plugin: ...} ]} ]
    sinks:      [ {plugin: csv_tracks, input: ins.pose} ]

Every component item has the common keys ``id`` (defaults to the plugin name),
``plugin`` (a name; ``name@package`` picks that installed package's plugin of the
name instead of the one the name means, a built-in's first), ``input`` (a stream or a list of streams; ``comp.port``, or ``comp`` when
it has one output port; shell-style wildcards allowed for sinks, matching every stream
but other sinks' own), ``agents`` (only
these firefighters), ``on_error`` (fault policy) and ``watchdog`` (seconds one call
into the plugin may take before it is interrupted and handled as a fault, 0: never;
the pipeline's top-level ``watchdog`` sets the default, else 60 s; see
:mod:`firenav_framework.watchdog`); all other keys are the plugin's parameters. Only safe YAML is read and plugins are looked up by name in the
registry: a pipeline can never import arbitrary code.
"""
from __future__ import annotations

import copy
import difflib
import fnmatch
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from .bus import FAULT_POLICIES
from .contract import Component, Params
from .contract.sink import output_name_problem
from .contract.context import PIPELINE_DIR
from .messages import Diagnostic, Message
from .plugin_docs import fields_at
from .registry import PluginInfo, Registry, default_registry, split_pin
from .timeline import TimelineConfig
from .watchdog import DEFAULT_LIMIT_S
from .yaml_locations import ConfigError, LocatedDocument, Problem, format_path, load, loads

SECTIONS = {"sources": "source", "sensors": "sensor", "estimators": "estimator",
            "sinks": "sink"}
TOP_KEYS = ("name", "description", "building", "timeline", "on_error", "watchdog", *SECTIONS)
COMMON_KEYS = ("id", "plugin", "input", "agents", "on_error", "watchdog")


@dataclass
class ComponentSpec:
    """One validated component of a pipeline."""

    id: str
    kind: str
    plugin: PluginInfo
    params: Params
    path: tuple
    inputs: list[str] = field(default_factory=list)
    agents: frozenset[str] | None = None
    on_error: str = "disable_agent"
    watchdog: float | None = DEFAULT_LIMIT_S  # time limit of one call [s]; None: not timed
    parent: str | None = None  # the estimator a constraint is attached to
    outputs: dict[str, type[Message]] = field(default_factory=dict)

    @property
    def cls(self) -> type[Component]:
        return self.plugin.cls


@dataclass
class PipelineSpec:
    """A validated pipeline, ready to be built by :mod:`firenav_framework.runner`."""

    name: str
    description: str
    file: str
    base_dir: Path
    building: Path | None
    timeline: TimelineConfig
    components: list[ComponentSpec]
    document: LocatedDocument
    #: located notes that do not stop the pipeline (printed by validate and run)
    warnings: list[Problem] = field(default_factory=list)

    def by_id(self, cid: str) -> ComponentSpec:
        return next(c for c in self.components if c.id == cid)

    def of_kind(self, kind: str) -> list[ComponentSpec]:
        return [c for c in self.components if c.kind == kind]

    def streams(self) -> dict[str, type[Message]]:
        """Every stream a component produces, by name."""
        return {f"{c.id}.{port}": t for c in self.components for port, t in c.outputs.items()}


# -- overrides ----------------------------------------------------------------------

def parse_override(expr: str) -> tuple[list[str], Any]:
    """``"estimators.pf.particles=1000"`` -> (["estimators", "pf", "particles"], 1000)."""
    if "=" not in expr:
        raise ConfigError([Problem("--set", None, None, expr, "expected KEY.PATH=VALUE")])
    key, value = expr.split("=", 1)
    parts: list[str] = []
    for chunk in key.strip().split("."):
        while "[" in chunk and chunk.endswith("]"):  # estimators[0] -> estimators, 0
            head, idx = chunk[:-1].split("[", 1)
            if head:
                parts.append(head)
            chunk = idx
        parts.append(chunk)
    if not all(parts):
        raise ConfigError([Problem("--set", None, None, expr, "empty part in the key path")])
    try:
        parsed = loads(value, "--set").data if value.strip() else ""
    except ConfigError as exc:
        raise ConfigError([Problem("--set", None, None, expr, f"bad value: {p.message}")
                           for p in exc.problems]) from None
    return parts, parsed


def apply_overrides(doc: LocatedDocument, exprs: list[str]) -> dict[tuple, str]:
    """Apply ``--set`` expressions to ``doc.data`` in place.

    A list item can be addressed by index or by its ``id`` (or plugin name when it
    has no id). Returns the overridden paths, so that errors in overridden values can
    point at the command line instead of the file.
    """
    done: dict[tuple, str] = {}
    for expr in exprs:
        parts, value = parse_override(expr)
        node: Any = doc.data
        path: list[str | int] = []
        for i, part in enumerate(parts):
            last = i == len(parts) - 1
            if isinstance(node, list):
                idx = _list_index(node, part)
                if idx is None:
                    names = [str(item.get("id", item.get("plugin"))) for item in node
                             if isinstance(item, dict)]
                    raise ConfigError([Problem("--set", None, None, expr,
                                               f"no item '{part}' in {format_path(tuple(path))}"
                                               f"{_did_you_mean(part, names)}")])
                key: str | int = idx
            elif isinstance(node, dict):
                key = part
            else:
                raise ConfigError([Problem("--set", None, None, expr,
                                           f"{format_path(tuple(path))} is not a mapping or list")])
            path.append(key)
            if last:
                node[key] = value
            else:
                if isinstance(node, dict) and key not in node:
                    node[key] = {}
                node = node[key]
        done[tuple(path)] = expr
    return done


def _list_index(items: list, part: str) -> int | None:
    if part.lstrip("-").isdigit():
        idx = int(part)
        return idx if -len(items) <= idx < len(items) else None
    for i, item in enumerate(items):
        if isinstance(item, dict) and item.get("id", item.get("plugin")) == part:
            return i
    return None


def _did_you_mean(word: str, options: list[str]) -> str:
    close = difflib.get_close_matches(word, options, n=3, cutoff=0.5)
    return f"; did you mean {' or '.join(repr(c) for c in close)}?" if close else ""


# -- validation ----------------------------------------------------------------------

def pydantic_message(err: dict) -> str:
    """Phrase a pydantic error for a field engineer."""
    kind, msg = err.get("type", ""), err.get("msg", "")
    if kind == "missing":
        return "missing required parameter"
    if kind == "extra_forbidden":
        return "unknown parameter"
    if msg.startswith("Input should be "):
        msg = "must be " + msg[len("Input should be "):]
    elif msg.startswith("Value error, "):
        msg = msg[len("Value error, "):]
    return msg


class _Validator:
    def __init__(self, doc: LocatedDocument, registry: Registry, overrides: dict[tuple, str]):
        self.doc = doc
        self.registry = registry
        self.overrides = overrides
        self.problems: list[Problem] = []
        #: what is worth saying but does not stop the pipeline (a shadowed plugin name)
        self.warnings: list[Problem] = []
        #: ids of components that failed validation: references to them are not re-reported
        self.failed: set[str] = set()

    def problem(self, path: tuple, message: str) -> None:
        for opath, expr in self.overrides.items():
            if path[:len(opath)] == opath:  # the problem is in (or below) an overridden value
                self.problems.append(Problem("--set", None, None, expr, message))
                return
        self.problems.append(self.doc.problem(path, message))

    def time_limit(self, value: Any, path: tuple) -> float | None:
        """A ``watchdog`` value: seconds > 0, or 0 / null for no limit."""
        if value is None or (isinstance(value, (int, float)) and not isinstance(value, bool)
                             and value == 0):
            return None
        if isinstance(value, bool) or not isinstance(value, (int, float)) \
                or not math.isfinite(value) or value < 0:
            self.problem(path, "watchdog must be a number of seconds (0: no limit)")
            return DEFAULT_LIMIT_S
        return float(value)

    def unknown_plugin(self, kind: str, name: str, pin: str | None) -> str:
        """Why no plugin answers to ``name`` (``@pin``): the closest names, or its
        import failure, or which packages offer it."""
        if pin is not None:
            default = self.registry.get(kind, name)
            offers = ([default.package] if default else []) + self.registry.offered_by(kind, name)
            return (f"no package '{pin}' offers {kind} plugin '{name}'" +
                    (f"; offered by {', '.join(offers)}" if offers else ""))
        failure = self.registry.load_problem(kind, name)
        if failure:
            return f"{kind} plugin '{name}' failed to load: {failure}"
        others = [p for p in self.registry.find(name)]
        hint = (f"; '{name}' is a {others[0].kind} plugin, not a {kind}" if others
                else _did_you_mean(name, self.registry.names(kind)))
        if not hint:
            hint = f"; known {kind} plugins: {', '.join(self.registry.names(kind)) or 'none'}"
        return f"unknown {kind} plugin '{name}'{hint}"

    def pydantic_problems(self, base: tuple, exc: ValidationError, model: type) -> None:
        for err in exc.errors():
            loc = base + tuple(err["loc"])
            message = pydantic_message(err)
            if err.get("type") == "extra_forbidden":
                known = fields_at(model, tuple(err["loc"])[:-1])   # of the group it is in
                message += (_did_you_mean(str(err["loc"][-1]), known)
                            or f"; known parameters: {', '.join(known) or 'none'}")
            self.problem(loc, message)

    def component(self, item: Any, path: tuple, kind: str, parent: str | None = None
                  ) -> ComponentSpec | None:
        if not isinstance(item, dict):
            self.problem(path, f"each {kind} must be a mapping with at least a 'plugin' key")
            return None
        name = item.get("plugin")
        if not isinstance(name, str) or not name:
            self.problem(path, "missing 'plugin': the name of the plugin to use")
            if isinstance(item.get("id"), str):
                self.failed.add(item["id"])
            return None
        name, pin = split_pin(name)
        info = self.registry.get(kind, name, package=pin)
        if info is None:
            self.failed.add(item.get("id", name) if isinstance(item.get("id", name), str) else name)
            self.problem(path + ("plugin",), self.unknown_plugin(kind, name, pin))
            return None
        offers = self.registry.offered_by(kind, name)
        if pin is None and offers:
            self.warnings.append(self.doc.problem(
                path + ("plugin",), f"'{name}' is also offered by {', '.join(offers)}; "
                f"{info.package}'s is used (write '{name}@<package>' to choose another)"))
        cls = info.cls
        cid = item.get("id", name)
        if not isinstance(cid, str) or not cid or "." in cid or "*" in cid:
            self.problem(path + ("id",), "id must be a non-empty name without '.' or '*'")
            cid = name
        inputs = item.get("input", [])
        if isinstance(inputs, str):
            inputs = [inputs]
        if not isinstance(inputs, list) or not all(isinstance(s, str) for s in inputs):
            self.problem(path + ("input",), "input must be a stream name or a list of them")
            inputs = []
        agents = item.get("agents")
        if agents is not None and (not isinstance(agents, list)
                                   or not all(isinstance(a, str) for a in agents)):
            self.problem(path + ("agents",), "agents must be a list of firefighter ids")
            agents = None
        watchdog = self.time_limit(item.get("watchdog", self.default_watchdog),
                                   path + ("watchdog",))
        on_error = item.get("on_error", self.default_policy)
        if on_error not in FAULT_POLICIES:
            self.problem(path + ("on_error",), f"on_error must be one of {', '.join(FAULT_POLICIES)}")
            on_error = "disable_agent"
        raw = {k: v for k, v in item.items() if k not in COMMON_KEYS and k != "constraints"}
        if "constraints" in item and kind != "estimator":
            self.problem(path + ("constraints",), "only estimators take constraints")
        try:
            params = cls.Params.model_validate(raw)
        except ValidationError as exc:
            self.pydantic_problems(path, exc, cls.Params)
            self.failed.add(cid)
            return None
        try:
            outputs = cls.output_ports(params)
        except Exception as exc:  # a plugin reporting e.g. an unreadable scenario file
            self.problem(path, f"{name}: {exc}")
            self.failed.add(cid)
            return None
        return ComponentSpec(id=cid, kind=kind, plugin=info, params=params, path=path,
                             inputs=inputs, agents=frozenset(agents) if agents else None,
                             on_error=on_error, watchdog=watchdog, parent=parent,
                             outputs=outputs)

    def run(self) -> tuple[list[ComponentSpec], TimelineConfig, str]:
        data = self.doc.data
        if not isinstance(data, dict):
            self.problem((), "a pipeline must be a mapping with sources, sensors, estimators, sinks")
            raise ConfigError(self.problems)
        for key in data:
            if key not in TOP_KEYS:
                self.problem((key,), f"unknown section{_did_you_mean(str(key), list(TOP_KEYS))}")
        name = data.get("name")
        if name is not None and (not isinstance(name, str) or output_name_problem(name)
                                 or "/" in name or "\\" in name or name == "."):
            self.problem(("name",), f"name {name!r} must be a plain name (no '/', no '..'): "
                         "it names the default output folder out/<name>")
        self.default_watchdog = self.time_limit(data.get("watchdog", DEFAULT_LIMIT_S),
                                                ("watchdog",))
        self.default_policy = data.get("on_error", "disable_agent")
        if self.default_policy not in FAULT_POLICIES:
            self.problem(("on_error",), f"on_error must be one of {', '.join(FAULT_POLICIES)}")
            self.default_policy = "disable_agent"
        try:
            timeline = TimelineConfig.model_validate(data.get("timeline") or {})
        except ValidationError as exc:
            self.pydantic_problems(("timeline",), exc, TimelineConfig)
            timeline = TimelineConfig()
        specs: list[ComponentSpec] = []
        for section, kind in SECTIONS.items():
            items = data.get(section) or []
            if not isinstance(items, list):
                self.problem((section,), f"{section} must be a list")
                continue
            for i, item in enumerate(items):
                spec = self.component(item, (section, i), kind)
                if spec is None:
                    continue
                specs.append(spec)
                if kind == "estimator":
                    cons = item.get("constraints") or []
                    if not isinstance(cons, list):
                        self.problem((section, i, "constraints"), "constraints must be a list")
                        continue
                    for j, citem in enumerate(cons):
                        c = self.component(citem, (section, i, "constraints", j),
                                           "constraint", parent=spec.id)
                        if c is not None:
                            specs.append(c)
        if not any(s.kind == "source" for s in specs) and not data.get("sources"):
            self.problem(("sources",), "a pipeline needs at least one source")
        return specs, timeline, str(data.get("name") or "")


def _check_wiring(v: _Validator, specs: list[ComponentSpec], has_building: bool) -> None:
    seen: dict[str, ComponentSpec] = {}
    for s in specs:
        if s.id in seen:
            line = v.doc.locate(seen[s.id].path)[0]
            v.problem(s.path + ("id",) if "id" in _item(v.doc, s.path) else s.path,
                      f"two components have the id '{s.id}' (the other is at line {line}); "
                      "give each a unique id")
        else:
            seen[s.id] = s
    streams: dict[str, type[Message]] = {}
    for s in specs:
        for port, mtype in s.outputs.items():
            streams[f"{s.id}.{port}"] = mtype
    streams["timeline.diagnostics"] = Diagnostic
    for s in specs:
        if s.id == "timeline":
            v.problem(s.path, "the id 'timeline' is reserved for the timeline's diagnostics")

    for s in specs:
        resolved: list[str] = []
        for j, ref in enumerate(s.inputs):
            where = s.path + ("input",) + ((j,) if len(s.inputs) > 1 or isinstance(
                _item(v.doc, s.path).get("input"), list) else ())
            matches = _resolve_stream(ref, streams, s, specs)
            if isinstance(matches, str):
                if ref.split(".")[0] not in v.failed:  # already reported at its source
                    v.problem(where, matches)
                continue
            for stream in matches:
                mtype = streams[stream]
                if s.cls.inputs and not issubclass(mtype, tuple(s.cls.inputs)):
                    accepted = ", ".join(t.__name__ for t in s.cls.inputs)
                    v.problem(where, f"stream '{stream}' carries {mtype.__name__} messages, "
                              f"but {s.plugin.name} reads {accepted}")
                elif not s.cls.inputs:
                    v.problem(where, f"{s.plugin.name} takes no input streams")
                elif stream.split(".")[0] == s.id:
                    v.problem(where, f"'{s.id}' cannot read its own output '{stream}'")
                else:
                    resolved.append(stream)
        s.inputs = resolved
        if s.kind in ("sensor", "estimator", "sink") and s.cls.inputs and not s.inputs \
                and "input" not in _item(v.doc, s.path):
            v.problem(s.path, f"{s.plugin.name} needs an 'input' stream "
                      f"({', '.join(t.__name__ for t in s.cls.inputs)})")
        if s.cls.needs_building and not has_building:
            v.problem(s.path, f"{s.plugin.name} needs a building: add 'building: PLAN' "
                      "to the pipeline (or use a source that brings one, like the simulator)")
        if s.kind == "constraint":
            parent = next((p for p in specs if p.id == s.parent and p.kind == "estimator"), None)
            if parent is not None and not issubclass(s.cls, parent.cls.accepts):
                offered = (", ".join(c.__name__ for c in parent.cls.accepts)
                           or "no constraints")
                v.problem(s.path + ("plugin",),
                          f"constraint '{s.plugin.name}' is a {s.cls.capability.__name__}; "
                          f"'{parent.id}' ({parent.plugin.name}) accepts {offered}")
    _check_cycles(v, specs)


def _item(doc: LocatedDocument, path: tuple) -> dict:
    node: Any = doc.data
    for part in path:
        node = node[part]
    return node if isinstance(node, dict) else {}


def _resolve_stream(ref: str, streams: dict[str, type[Message]], s: ComponentSpec,
                    specs: list[ComponentSpec]) -> list[str] | str:
    if any(ch in ref for ch in "*?["):
        if s.kind != "sink":
            return f"wildcards like '{ref}' are only allowed for sinks"
        sinks = {c.id for c in specs if c.kind == "sink"}
        found = sorted(k for k in streams if fnmatch.fnmatchcase(k, ref)
                       and k.split(".")[0] not in sinks)  # sinks' streams only by name
        return found or f"'{ref}' matches no stream; known streams: {', '.join(sorted(streams))}"
    if ref in streams:
        return [ref]
    comp = next((c for c in specs if c.id == ref), None)
    if comp is not None:
        ports = [p for p in comp.outputs if p != "diagnostics"]
        if len(ports) == 1:
            return [f"{ref}.{ports[0]}"]
        return (f"'{ref}' has several output ports ({', '.join(ports)}); "
                f"name one, e.g. '{ref}.{ports[0]}'" if ports else f"'{ref}' produces nothing")
    hint = _did_you_mean(ref, list(streams)) or f"; known streams: {', '.join(sorted(streams))}"
    return f"stream '{ref}' is produced by nobody{hint}"


def _check_cycles(v: _Validator, specs: list[ComponentSpec]) -> None:
    graph = {s.id: {i.split(".")[0] for i in s.inputs} for s in specs}
    state: dict[str, int] = {}

    def visit(node: str, trail: list[str]) -> None:
        state[node] = 1
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                loop = trail[trail.index(nxt):] + [nxt] if nxt in trail else [node, nxt]
                v.problem(next(s.path for s in specs if s.id == node),
                          f"streams form a loop: {' -> '.join(loop)}")
            elif nxt not in state:
                visit(nxt, trail + [nxt])
        state[node] = 2

    for s in specs:
        if s.id not in state:
            visit(s.id, [s.id])


def validate_document(doc: LocatedDocument, *, registry: Registry | None = None,
                      base_dir: Path | None = None, overrides: dict[tuple, str] | None = None
                      ) -> PipelineSpec:
    """Validate parsed pipeline data; raises :class:`ConfigError` listing every problem."""
    registry = registry or default_registry()
    base_dir = base_dir or Path(doc.file).resolve().parent
    v = _Validator(doc, registry, overrides or {})
    token = PIPELINE_DIR.set(base_dir)
    try:
        specs, timeline, name = v.run()
    finally:
        PIPELINE_DIR.reset(token)
    data = doc.data
    building = None
    if data.get("building") is not None:
        if not isinstance(data["building"], str):
            v.problem(("building",), "building must be a file path")
        else:
            building = Path(data["building"]).expanduser()
            building = building if building.is_absolute() else base_dir / building
            if not building.exists():
                v.problem(("building",), f"building plan '{data['building']}' not found "
                          f"(looked for {building})")
            else:
                from .building.loader import plan_problem
                problem = plan_problem(building)
                if problem:
                    v.problem(("building",), problem)
    source_building = any(s.cls.provides_building for s in specs if s.kind == "source")
    _check_wiring(v, specs, building is not None or source_building)
    if v.problems:
        raise ConfigError(v.problems)
    return PipelineSpec(name=name or Path(doc.file).stem,
                        description=str(data.get("description") or ""), file=doc.file,
                        base_dir=base_dir, building=building, timeline=timeline,
                        components=specs, document=doc, warnings=v.warnings)


def load_pipeline(path: str | Path, overrides: list[str] = (), *,
                  registry: Registry | None = None) -> PipelineSpec:
    """Read, override and validate a pipeline file."""
    doc = load(path)
    doc.data = copy.deepcopy(doc.data)
    done = apply_overrides(doc, list(overrides)) if overrides else {}
    return validate_document(doc, registry=registry, overrides=done)


def load_pipeline_text(text: str, *, file: str = "<string>", base_dir: Path | None = None,
                       overrides: list[str] = (), registry: Registry | None = None
                       ) -> PipelineSpec:
    """Validate a pipeline given as text (tests, embedding)."""
    doc = loads(text, file)
    done = apply_overrides(doc, list(overrides)) if overrides else {}
    return validate_document(doc, registry=registry, base_dir=base_dir or Path.cwd(),
                             overrides=done)
