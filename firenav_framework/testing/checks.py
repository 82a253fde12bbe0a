"""The conformance checks of a plugin class, each usable on its own.

Every check takes a :class:`PluginCase` (the class, its parameters, sample input, a
building, a host estimator for a constraint, a scratch folder) and raises
:class:`CheckFailed` with every problem it found, or :class:`NotApplicable` with the
reason it does not apply to this plugin. :data:`CHECKS` lists them in the order
:func:`~firenav_framework.testing.check_plugin` runs them:

=================  ===========================================================================
check              what it asserts
=================  ===========================================================================
``class``          a role base of the contract, a name, every abstract hook implemented, a
                   docstring summary, Message types for inputs and outputs, hook
                   signatures the runner can call; a constraint subclasses a capability
``parameter_docs`` every parameter, in nested groups too, has a description; a parameter
                   whose name or type says it is a physical quantity has an SI unit
``declared_ports`` ``output_ports`` and ``tick_period`` are consistent: Message types per
                   port, ``diagnostics`` present, a period that is None or positive, the
                   same answer on every call
``ports``          on the sample input, everything published goes to a declared port with
                   its declared type and a finite time, diagnostics name the component,
                   and no received message is changed in place
``capability``     (constraints) the host estimator calls the capability's methods and
                   every answer has the type the capability declares
``bad_input``      a NaN, an infinite value, empty arrays (where the message type allows
                   them), a copy naming a firefighter the device is not theirs, or two
                   messages out of time order: nothing raises, no
                   non-finite value leaks into the output, and a change of output is
                   counted (``ctx.count``) or reported (a warning or error diagnostic);
                   a source is run on the damaged data its case names
``reset_refeed``   after ``reset(agent)`` and the same input again (later), the output for
                   that firefighter equals a fresh instance's
``deterministic``  two fresh instances given the same input publish identical messages
                   and write identical files
``live_stop``      (live sources) ``stop()`` makes a running ``messages()`` return soon
=================  ===========================================================================
"""
from __future__ import annotations

import dataclasses
import inspect
import math
import re
import tempfile
import threading
import typing
from collections import Counter
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import BaseModel

from ..contract import Component, Constraint, Estimator, Params, Source
from ..contract.params import Angle, AngularRate
from ..messages import Diagnostic, Message
from ..registry import plugin_class_problem
from .harness import HOST, UNDER_TEST, Recorder, Session

__all__ = ["CheckFailed", "NotApplicable", "PluginCase", "CHECKS", "PASSED", "check",
           "registrar", "run_registered", "raise_problems", "parameter_problems", "host_for"]


class CheckFailed(AssertionError):
    """A plugin breaks the contract; the message lists every problem found."""


class NotApplicable(Exception):
    """A check that does not apply to this plugin (the message says why)."""


def raise_problems(problems: Iterable[str], what: str) -> None:
    """Raise :class:`CheckFailed` listing ``problems`` under ``what``, if there are any."""
    problems = list(problems)
    if problems:
        raise CheckFailed(f"{what}:\n  " + "\n  ".join(problems))


@dataclass
class PluginCase:
    """What the checks run one plugin class with.

    ``sample`` is the input fed to sensors, estimators, constraints and sinks;
    ``faulty_params`` are parameter sets of a source pointing at damaged data (the
    bad-input check of a source runs each). ``host`` (and ``host_params``) is the
    estimator a constraint is attached to. The plain run on the sample writes its files into ``output_dir``
    (when given), every other run into a folder of its own under ``workdir``.
    """

    cls: type[Component]
    params: Params
    sample: list[tuple[str, Message]] = field(default_factory=list)
    building: Any = None
    host: type[Estimator] | None = None
    host_params: dict | BaseModel | None = None
    faulty_params: list[dict] = field(default_factory=list)
    output_dir: Path | None = None
    base_dir: Path | None = None
    workdir: Path = field(default_factory=lambda: Path(tempfile.mkdtemp(prefix="firenav-check-")))
    _runs: int = field(default=0, init=False, repr=False)
    _clean: tuple[Session, Recorder] | None = field(default=None, init=False, repr=False)

    @property
    def name(self) -> str:
        return f"{self.cls.kind} '{self.cls.name}' ({self.cls.__name__})"

    def session(self, params: dict | BaseModel | None = None, *,
                output_dir: Path | None = None) -> Session:
        """A fresh instance writing into its own output folder (a new one under
        ``workdir`` unless given)."""
        self._runs += 1
        out = output_dir if output_dir is not None else self.workdir / f"run{self._runs}"
        return Session(self.cls, self.params if params is None else params,
                       building=self.building, base_dir=self.base_dir, output_dir=out,
                       host=self.host, host_params=self.host_params)

    def clean(self) -> tuple[Session, Recorder]:
        """The plain run on the sample input, writing into ``output_dir`` if given (run
        once, shared by the checks)."""
        if self._clean is None:
            s = self.session(output_dir=self.output_dir)
            self._clean = (s, s.run(self.sample))
        return self._clean


Check = Callable[[Any], None]

#: The checks in the order they run: name -> check.
CHECKS: dict[str, Check] = {}
#: What a check that passed answers in :func:`run_registered`'s results.
PASSED = "passed"


def registrar(table: dict[str, Check]) -> Callable[[str], Callable[[Check], Check]]:
    """A decorator ``@register(name)`` adding checks to ``table`` in definition order (a
    check's docstring's first line says what it asserts)."""
    def register(name: str) -> Callable[[Check], Check]:
        def add(fn: Check) -> Check:
            table[name] = fn
            return fn
        return add
    return register


check = registrar(CHECKS)


def run_registered(table: dict[str, Check], case: Any, checks: Iterable[str] | None = None,
                   exclude: Iterable[str] = ()) -> dict[str, Any]:
    """Run ``checks`` of ``table`` (default: all, minus ``exclude``) on ``case``: name ->
    ``"passed"``, ``"n/a: <why>"`` or the exception it raised.

    The ``class`` check always runs first; when it fails nothing else can run, and the
    other checks are not attempted.
    """
    names = list(table) if checks is None else list(checks)
    unknown = [n for n in [*names, *exclude] if n not in table]
    if unknown:
        raise ValueError(f"unknown checks {unknown}; known: {', '.join(table)}")
    names = ["class", *(n for n in names if n not in set(exclude) and n != "class")]
    results: dict[str, Any] = {}
    for name in names:
        try:
            table[name](case)
        except NotApplicable as why:
            results[name] = f"n/a: {why}"
        except Exception as exc:
            results[name] = exc
            if name == "class":
                break
        else:
            results[name] = PASSED
    return results


# -- class ------------------------------------------------------------------------------
_HOOKS = {"source": "messages", "sensor": "handle", "estimator": "handle",
          "constraint": "handle", "sink": "handle"}


@check("class")
def check_class(case: PluginCase) -> None:
    """The class is a well-formed plugin of its kind."""
    cls = case.cls
    problem = plugin_class_problem(cls)
    if problem:
        raise CheckFailed(problem)
    problems = []
    if not cls.summary():
        problems.append(f"{cls.__name__} needs a docstring: its first line is the summary "
                        f"`firenav plugins list` shows")
    if not isinstance(cls.inputs, tuple) or not all(_is_message_type(t) for t in cls.inputs):
        problems.append(f"inputs must be a tuple of Message types, got {cls.inputs!r}")
    if not isinstance(cls.outputs, dict) or not all(
            isinstance(k, str) and _is_message_type(v) for k, v in cls.outputs.items()):
        problems.append(f"outputs must map port names to Message types, got {cls.outputs!r}")
    if cls.kind == "source" and cls.inputs:
        problems.append("a source has no inputs (it produces messages)")
    if cls.kind in ("sensor", "estimator", "sink") and not cls.inputs:
        problems.append(f"a {cls.kind} needs inputs: the message types it accepts")
    hook = _HOOKS[cls.kind]
    if cls.kind != "constraint" or cls.inputs:
        arity = 1 if hook == "messages" else 3
        try:
            inspect.signature(getattr(cls, hook)).bind(*range(arity))
        except TypeError as exc:
            problems.append(f"{hook}() cannot be called as the runner calls it "
                            f"({'self' if arity == 1 else 'self, stream, msg'}): {exc}")
    if cls.kind == "source" and cls.input_param and cls.input_param not in cls.Params.model_fields:
        problems.append(f"input_param {cls.input_param!r} is not a parameter")
    for name in ("start", "finish"):
        try:
            inspect.signature(getattr(cls, name)).bind(None)
        except TypeError as exc:
            problems.append(f"{name}() takes no arguments besides self: {exc}")
    try:
        inspect.signature(cls.reset).bind(None, "ff1")
    except TypeError as exc:
        problems.append(f"reset() takes the agent: {exc}")
    raise_problems(problems, f"{case.name} is not a well-formed plugin")


def _is_message_type(t: object) -> bool:
    return isinstance(t, type) and issubclass(t, Message)


# -- parameters -------------------------------------------------------------------------
#: Name endings that state a unit; such a parameter must declare it (``param(unit=...)``).
_UNIT_SUFFIX = re.compile(r"_(m|m2|m3|cm|mm|km|s|ms|us|min|h|hz|khz|rad|deg|dps|rads|mps|"
                          r"mps2|dbm|db|ut|g|kb|mb|mib|b|bps)$")
#: Name endings (or a whole name) that state degrees: parameters are SI (radians).
_DEGREES_NAME = re.compile(r"(^|_)(deg|degs|degrees|dps|deg_s|deg_per_s)$")
#: Units that are degrees (use Angle / AngularRate, which accept them in YAML).
_DEGREE_UNITS = {"deg", "degree", "degrees", "°", "deg/s", "deg/min", "deg/h", "dps"}
#: Words that make a real-valued parameter a physical quantity needing a unit.
_QUANTITY_WORDS = {"period", "duration", "timeout", "interval", "delay", "latency", "age",
                   "radius", "distance", "length", "width", "height", "depth", "spacing",
                   "speed", "velocity", "acceleration", "heading", "yaw", "pitch", "roll",
                   "angle", "bearing", "position", "offset"}
#: Words that make a parameter a ratio ("per metre", a scale): its suffix is no unit.
_RATIO_WORDS = {"per", "ratio", "fraction", "factor", "scale", "gain", "relative", "rel"}


def _unit(field_info: Any) -> str | None:
    extra = field_info.json_schema_extra
    return extra.get("unit") if isinstance(extra, dict) else None


def _angle_kind(field_info: Any) -> str | None:
    """"rad" for an :data:`Angle` parameter, "rad/s" for an :data:`AngularRate`."""
    markers = {id(Angle.__metadata__[0]): "rad", id(AngularRate.__metadata__[0]): "rad/s"}
    found = [markers[id(m)] for m in field_info.metadata if id(m) in markers]
    stack = [field_info.annotation]
    while stack:
        ann = stack.pop()
        found += [markers[id(m)] for m in getattr(ann, "__metadata__", ()) if id(m) in markers]
        stack.extend(typing.get_args(ann))
    return found[0] if found else None


def _is_real(annotation: Any) -> bool:
    """A float, or a tuple/optional of floats (a vector) - not an int, str or model."""
    if annotation is float:
        return True
    args = [a for a in typing.get_args(annotation) if a is not type(None) and a is not Ellipsis]
    return bool(args) and all(_is_real(a) for a in args)


def _models_in(annotation: Any) -> Iterator[type[BaseModel]]:
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        yield annotation
        return
    for arg in typing.get_args(annotation):
        yield from _models_in(arg)


def param_fields(model: type[BaseModel], prefix: str = "",
                 seen: frozenset = frozenset()) -> Iterator[tuple[str, Any]]:
    """``(dotted name, FieldInfo)`` of every parameter of ``model``, nested groups included."""
    for name, info in model.model_fields.items():
        yield prefix + name, info
        for sub in _models_in(info.annotation):
            if sub not in seen:
                yield from param_fields(sub, f"{prefix}{name}.", seen | {model})


def parameter_problems(model: type[BaseModel]) -> list[str]:
    """What the parameter docs of ``model`` lack (see :func:`check_parameter_docs`)."""
    problems = []
    for name, info in param_fields(model):
        leaf = name.rsplit(".", 1)[-1].lower()
        unit = _unit(info)
        angle = _angle_kind(info)
        words = set(leaf.split("_"))
        if not (info.description or "").strip():
            problems.append(f"{name}: no description (a docstring right below the "
                            f"parameter, or param(description=...))")
        if _DEGREES_NAME.search(leaf) or (unit or "").strip().lower() in _DEGREE_UNITS:
            problems.append(f"{name}: degrees (parameters are SI: declare it Angle or "
                            f"AngularRate, in radians; YAML may still say '5 deg')")
        elif angle and unit != angle:
            problems.append(f"{name}: an {'AngularRate' if angle == 'rad/s' else 'Angle'} "
                            f"needs unit={angle!r}, has {unit!r}")
        elif not unit and not words & _RATIO_WORDS and (_UNIT_SUFFIX.search(leaf) or (
                _is_real(info.annotation) and words & _QUANTITY_WORDS)):
            problems.append(f"{name}: a physical quantity without a unit (param(unit=...))")
    return problems


@check("parameter_docs")
def check_parameter_docs(case: PluginCase) -> None:
    """Every parameter is described and physical quantities carry SI units."""
    raise_problems(parameter_problems(case.cls.Params), f"{case.name}: parameter docs")


# -- declared ports and ticks -----------------------------------------------------------
_PORT = re.compile(r"^[A-Za-z_][A-Za-z0-9_-]*$")


@check("declared_ports")
def check_declared_ports(case: PluginCase) -> None:
    """``output_ports`` and ``tick_period`` agree with each other and the contract."""
    cls, params, problems = case.cls, case.params, []
    ports = cls.output_ports(params)
    if not isinstance(ports, dict):
        raise CheckFailed(f"{case.name}: output_ports() returned {ports!r}, not a dict")
    for port, mtype in ports.items():
        if not isinstance(port, str) or not _PORT.match(port):
            problems.append(f"port name {port!r} is not a plain name (letters, digits, _ -)")
        if not _is_message_type(mtype):
            problems.append(f"port {port!r} maps to {mtype!r}, not a Message type")
    if ports.get("diagnostics") is not Diagnostic:
        problems.append("output_ports() lacks 'diagnostics': Diagnostic (call "
                        "super().output_ports(params) when overriding it)")
    if cls.output_ports(params) != ports:
        problems.append("output_ports() answers differently when asked twice")
    period = cls.tick_period(params)
    if period is not None and not (isinstance(period, (int, float)) and math.isfinite(period)
                                   and period > 0):
        problems.append(f"tick_period() must be None or a positive number of seconds, "
                        f"got {period!r}")
    if cls.tick_period(params) != period:
        problems.append("tick_period() answers differently when asked twice")
    raise_problems(problems, f"{case.name}: declared ports and ticks")


# -- ports ------------------------------------------------------------------------------
def _float_values(msg: Message) -> Iterator[tuple[str, np.ndarray]]:
    for f in dataclasses.fields(msg):
        v = getattr(msg, f.name)
        if isinstance(v, (float, np.floating)) and not isinstance(v, bool):
            yield f.name, np.asarray(v)
        elif isinstance(v, np.ndarray) and v.dtype.kind == "f":
            yield f.name, v


@check("ports")
def check_ports(case: PluginCase) -> None:
    """On the sample input, everything published goes to a declared port, typed."""
    if not case.sample and case.cls.kind != "source":
        raise NotApplicable("no sample input for this plugin's inputs")
    if case.cls.kind == "source" and case.cls.live:
        raise NotApplicable("a live source needs its link (see live_stop)")
    before = [m.digest() for _, m in case.sample]
    session, rec = case.clean()
    problems = []
    declared = {UNDER_TEST: case.cls.output_ports(case.params)}
    problems += [f"world_outputs names {port!r}, which is not an output port (declared: "
                 f"{', '.join(declared[UNDER_TEST])})"
                 for port in case.cls.world_outputs if port not in declared[UNDER_TEST]]
    if session.host is not None:
        declared[HOST] = type(session.host).output_ports(session.host.params)
    for cid, port, msg in rec.records:
        ports = declared[cid]
        who = case.cls.__name__ if cid == UNDER_TEST else f"host {type(session.host).__name__}"
        if port not in ports:
            problems.append(f"{who} published {type(msg).__name__} on undeclared port "
                            f"{port!r} (declared: {', '.join(ports)})")
        elif not isinstance(msg, ports[port]):
            problems.append(f"{who} published {type(msg).__name__} on {port!r}, declared "
                            f"{ports[port].__name__}")
        if not math.isfinite(float(msg.t)):
            problems.append(f"{who} published {type(msg).__name__} on {port!r} with time {msg.t}")
        if isinstance(msg, Diagnostic) and msg.component != cid:
            problems.append(f"{who} published a diagnostic naming component {msg.component!r}, "
                            f"not its own id {cid!r} (use ctx.diagnose / ctx.report)")
    changed = {type(m).__name__ for (_, m), d in zip(case.sample, before) if m.digest() != d}
    if changed:
        problems.append(f"changed received messages in place ({', '.join(sorted(changed))}): "
                        f"messages are shared by every receiver; publish new ones")
    raise_problems(_first(problems), f"{case.name}: ports")


def _first(problems: list[str], n: int = 10) -> list[str]:
    """At most ``n`` distinct problems (a problem repeated per message is said once)."""
    distinct = list(dict.fromkeys(problems))
    return distinct[:n] + ([f"... and {len(distinct) - n} more"] if len(distinct) > n else [])


# -- capability -------------------------------------------------------------------------
@check("capability")
def check_capability(case: PluginCase) -> None:
    """A constraint's capability methods are called by its host and answer in type."""
    cls = case.cls
    if cls.kind != "constraint":
        raise NotApplicable("not a constraint")
    if case.host is None:
        raise CheckFailed(f"{case.name}: no estimator to host it (no registered estimator "
                          f"accepts {cls.capability.__name__}; pass host=)")
    if not any(issubclass(cls, cap) for cap in case.host.accepts):
        raise CheckFailed(f"{case.name}: host {case.host.__name__} does not accept "
                          f"{cls.capability.__name__} (accepts: "
                          f"{', '.join(c.__name__ for c in case.host.accepts) or 'nothing'})")
    session = case.session()
    calls: Counter = Counter()
    problems: list[str] = []
    for hook in cls.hooks:
        _watch(session.component, hook, calls, problems)
    session.run(case.sample)
    if not any(calls[h] for h in cls.hooks):
        problems.append(f"host {case.host.__name__} never called {' or '.join(cls.hooks)} on "
                        f"the sample input: the sample does not exercise this constraint")
    raise_problems(_first(problems), f"{case.name}: capability {cls.capability.__name__}")


def _watch(component: Constraint, hook: str, calls: Counter, problems: list[str]) -> None:
    """Wrap ``component.hook`` to count calls and check each answer against the return
    annotation the capability declares."""
    method = getattr(component, hook)
    declared = typing.get_type_hints(getattr(type(component).capability, hook)).get("return")
    allowed = tuple(a for a in (typing.get_args(declared) or (declared,))
                    if isinstance(a, type)) if declared is not None else ()

    def watched(*args: Any, **kw: Any) -> Any:
        answer = method(*args, **kw)
        calls[hook] += 1
        if allowed and not isinstance(answer, allowed):
            problems.append(f"{hook}() answered {type(answer).__name__}, declared "
                            f"{' | '.join(a.__name__ for a in allowed)}")
        return answer

    setattr(component, hook, watched)


# -- bad input --------------------------------------------------------------------------
def _outputs(rec: Recorder, agents: Iterable[str] | None = None,
             leave_out: Iterable[str] = ()) -> list[tuple[str, str, Message]]:
    """What was published apart from diagnostics and the ports ``leave_out`` (for
    ``agents`` only)."""
    agents = None if agents is None else set(agents)
    skip = {"diagnostics", *leave_out}
    return [(cid, port, msg) for cid, port, msg in rec.records
            if port not in skip and (agents is None or msg.agent in agents)]


#: Relative and absolute tolerance of "the same output" after a different history
#: (a solver's round-off depends on its internal order; exact equality is for
#: :func:`check_deterministic`).
SAME_RTOL, SAME_ATOL = 1e-9, 1e-9


def _same(a: Message, b: Message) -> bool:
    if type(a) is not type(b):
        return False
    for f in dataclasses.fields(a):
        x, y = getattr(a, f.name), getattr(b, f.name)
        if isinstance(x, (np.ndarray, float, np.floating)) and not isinstance(x, bool):
            x, y = np.asarray(x), np.asarray(y)
            if x.shape != y.shape or (x.dtype.kind in "fc" and not np.allclose(
                    x, y, rtol=SAME_RTOL, atol=SAME_ATOL, equal_nan=True)) or (
                    x.dtype.kind not in "fc" and not np.array_equal(x, y)):
                return False
        elif x != y:
            return False
    return True


def _first_difference(a: list[tuple[str, str, Message]], b: list[tuple[str, str, Message]]
                      ) -> int | None:
    """Index of the first output that differs (None: the same, within tolerance)."""
    for k, ((c1, p1, m1), (c2, p2, m2)) in enumerate(zip(a, b)):
        if (c1, p1) != (c2, p2) or not _same(m1, m2):
            return k
    return None if len(a) == len(b) else min(len(a), len(b))


def _problems_noted(session: Session, rec: Recorder) -> Counter:
    """Counts plus active warning/error diagnostics of a run, by (component, name)."""
    noted: Counter = Counter()
    for cid, counts in session.stats.counts.items():
        for what, n in counts.items():
            noted[(cid, what)] += n
    for cid, _, msg in rec.records:
        if isinstance(msg, Diagnostic) and msg.level in ("warning", "error") and msg.active:
            noted[(cid, f"diagnostic {msg.code}")] += 1
    return noted


def _non_finite(rec: Recorder) -> set[tuple[str, str, str]]:
    return {(cid, port, name) for cid, port, msg in rec.records if port != "diagnostics"
            for name, v in _float_values(msg) if not np.all(np.isfinite(v))}


def _corrupt_floats(msg: Message, value: float) -> Message | None:
    """``msg`` with ``value`` in every real-valued field except its time ``t`` (arrays:
    in their middle element); None when it has none."""
    changes = {}
    for name, v in _float_values(msg):
        if name == "t":
            continue
        if v.ndim == 0:
            changes[name] = value
        elif v.size:
            w = v.copy()
            w.reshape(-1)[w.size // 2] = value
            changes[name] = w
    return _replace(msg, changes)


def _emptied(msg: Message) -> Message | None:
    """``msg`` with its arrays and byte strings empty, if its type allows that."""
    changes = {}
    for f in dataclasses.fields(msg):
        v = getattr(msg, f.name)
        if isinstance(v, np.ndarray) and v.size:
            changes[f.name] = np.empty((0,) + v.shape[1:], dtype=v.dtype)
        elif isinstance(v, (bytes, bytearray)) and v:
            changes[f.name] = b""
    return _replace(msg, changes)


def _replace(msg: Message, changes: dict) -> Message | None:
    if not changes:
        return None
    try:
        return dataclasses.replace(msg, **changes)
    except (ValueError, TypeError):  # the message type itself refuses it
        return None


#: kind of damage -> (what it is, how a message is damaged; None: not applicable)
_DAMAGE: dict[str, tuple[str, Callable[[Message], Message | None]]] = {
    "nan": ("a NaN value", lambda m: _corrupt_floats(m, math.nan)),
    "inf": ("an infinite value", lambda m: _corrupt_floats(m, math.inf)),
    "empty": ("empty arrays", _emptied),
}
#: The firefighter a misaddressed copy names (no sample mentions it).
STRANGER = "ff_stranger"


def _victim(sample: list[tuple[str, Message]], mtype: type) -> int | None:
    """Index of the message of type ``mtype`` (exactly) to damage: 40 % into that type's
    messages, preferring the first firefighter's."""
    idx = [i for i, (_, m) in enumerate(sample) if type(m) is mtype]
    if not idx:
        return None
    agents = sorted({sample[i][1].agent for i in idx if sample[i][1].agent})
    own = [i for i in idx if agents and sample[i][1].agent == agents[0]] or idx
    return own[int(0.4 * len(own))]


def damaged_samples(sample: list[tuple[str, Message]]
                    ) -> Iterator[tuple[str, list[tuple[str, Message]]]]:
    """(description, damaged copy of ``sample``): each kind of damage to one message of
    each message type in it, a misaddressed copy of it inserted, and it swapped in time
    with the next message of its device."""
    for mtype in sorted({type(m) for _, m in sample}, key=lambda t: t.__name__):
        i = _victim(sample, mtype)
        if i is None:
            continue
        stream, msg = sample[i]
        where = f"{mtype.__name__} at t={float(msg.t):.2f} s"
        for what, damage in _DAMAGE.values():
            bad = damage(msg)
            if bad is not None:
                yield f"{what} in the {where}", [*sample[:i], (stream, bad), *sample[i + 1:]]
        stranger = dataclasses.replace(msg, agent=STRANGER)
        yield (f"a copy of the {where} naming firefighter {STRANGER!r} (its device "
               f"{msg.device!r} is someone else's)", [*sample[:i + 1], (stream, stranger),
                                                      *sample[i + 1:]])
        j = next((j for j in range(i + 1, len(sample)) if type(sample[j][1]) is mtype
                  and sample[j][1].device == msg.device and sample[j][1].agent == msg.agent
                  and sample[j][1].t > msg.t), None)
        if j is not None:
            swapped = list(sample)
            swapped[i], swapped[j] = swapped[j], swapped[i]
            yield f"the {where} delivered after a later one (out of time order)", swapped


@check("bad_input")
def check_bad_input(case: PluginCase) -> None:
    """Bad input raises nothing, leaks no NaN and is counted or reported where it matters."""
    if case.cls.kind == "source":
        return _check_bad_source_data(case)
    if not case.sample:
        raise NotApplicable("no sample input for this plugin's inputs")
    clean_session, clean_rec = case.clean()
    agents = {m.agent for _, m in case.sample if m.agent}
    clean_out = _outputs(clean_rec, agents)
    clean_noted = _problems_noted(clean_session, clean_rec)
    clean_nonfinite = _non_finite(clean_rec)
    problems = []
    for what, sample in damaged_samples(case.sample):
        session = case.session()
        try:
            rec = session.run(sample)
        except Exception as exc:
            problems.append(f"{what}: {type(exc).__name__} escaped: {exc}")
            continue
        leaked = _non_finite(rec) - clean_nonfinite
        if leaked:
            problems.append(f"{what}: non-finite values published in " + ", ".join(
                f"{port}.{name}" for _, port, name in sorted(leaked)))
        noted = _problems_noted(session, rec)
        if _first_difference(_outputs(rec, agents), clean_out) is not None and not any(
                n > clean_noted[k] for k, n in noted.items()):
            problems.append(f"{what}: the output changed but nothing was counted "
                            f"(ctx.count) or reported (ctx.report / a warning diagnostic)")
    raise_problems(problems, f"{case.name}: bad input")


def _check_bad_source_data(case: PluginCase) -> None:
    if not case.faulty_params:
        raise NotApplicable("a source's bad input is in its data: give faulty_params "
                            "(parameters pointing at damaged data) to check it")
    problems = []
    for params in case.faulty_params:
        session = case.session(params)
        try:
            rec = session.run()
        except Exception as exc:
            problems.append(f"{params}: {type(exc).__name__} escaped: {exc}")
            continue
        if not _problems_noted(session, rec):
            problems.append(f"{params}: the damaged data was neither counted nor reported")
    raise_problems(problems, f"{case.name}: bad input")


# -- reset ------------------------------------------------------------------------------
def _time_span(sample: list[tuple[str, Message]]) -> float:
    times = [float(m.t) for _, m in sample]
    return max(times) - min(times)


@check("reset_refeed")
def check_reset_refeed(case: PluginCase) -> None:
    """After reset(agent), the same input again gives a fresh instance's output (its
    ``world_outputs``, building facts that outlive the firefighter's state, apart)."""
    if case.cls.kind == "source":
        raise NotApplicable("a source holds no per-firefighter state")
    agents = sorted({m.agent for _, m in case.sample if m.agent})
    if not agents:
        raise NotApplicable("the sample input names no firefighter")
    agent = agents[0]
    own = [(s, m) for s, m in case.sample if m.agent == agent]
    later = math.ceil(_time_span(case.sample) + 10.0)
    again = [(s, m.shifted(later)) for s, m in own]
    fresh = case.session()
    world = case.cls.world_outputs
    fresh_out = _outputs(fresh.run(again), [agent], world)
    if not fresh_out:
        raise NotApplicable(f"publishes nothing for '{agent}' from its messages alone")
    used = case.session().start()
    used.feed(own)
    used.reset(agent)
    mark = len(used.recorder.records)
    used.feed(again)
    used.finish()
    after = Recorder(used.recorder.cid)
    after.records = used.recorder.records[mark:]
    got = _outputs(after, [agent], world)
    k = _first_difference(got, fresh_out)
    if k is not None:
        raise CheckFailed(
            f"{case.name}: after reset('{agent}') and {len(again)} of its messages again "
            f"({later} s later), it published {len(got)} messages for '{agent}' that differ "
            f"from a fresh instance's {len(fresh_out)} (first difference at message {k}: "
            f"{_describe(got, k)} instead of {_describe(fresh_out, k)}): reset must forget "
            f"everything of that firefighter")


def _describe(out: list[tuple[str, str, Message]], k: int) -> str:
    if k >= len(out):
        return "nothing"
    _, port, msg = out[k]
    return f"{type(msg).__name__} on {port!r} at t={float(msg.t):.2f} s"


# -- determinism ------------------------------------------------------------------------
def _files(folder: Path | None) -> dict[str, bytes]:
    if folder is None or not folder.is_dir():
        return {}
    return {p.relative_to(folder).as_posix(): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


@check("deterministic")
def check_deterministic(case: PluginCase) -> None:
    """Two fresh instances given the same input publish and write the same."""
    if case.cls.kind == "source" and case.cls.live:
        raise NotApplicable("a live source's output is what its link delivers")
    if not case.sample and case.cls.kind != "source":
        raise NotApplicable("no sample input for this plugin's inputs")
    first, rec1 = case.clean()
    second = case.session()
    rec2 = second.run(case.sample)
    problems = []
    a = [(c, p, m.digest()) for c, p, m in rec1.records]
    b = [(c, p, m.digest()) for c, p, m in rec2.records]
    if a != b:
        k = next((k for k, (x, y) in enumerate(zip(a, b)) if x != y), min(len(a), len(b)))
        problems.append(f"published {len(a)} then {len(b)} messages; the first difference "
                        f"is message {k}: {_describe(rec1.records, k)} the first time, "
                        f"{_describe(rec2.records, k)} the second")
    files1, files2 = _files(first._output_dir), _files(second._output_dir)
    if files1 != files2:
        differ = sorted(n for n in set(files1) | set(files2) if files1.get(n) != files2.get(n))
        problems.append(f"wrote different files: {', '.join(differ)}")
    raise_problems(problems, f"{case.name}: not deterministic")


# -- live sources -----------------------------------------------------------------------
#: How long [s] a live source may take to return from messages() after stop().
STOP_WITHIN_S = 5.0


@check("live_stop")
def check_live_stop(case: PluginCase) -> None:
    """A live source's messages() returns soon after stop()."""
    if case.cls.kind != "source" or not case.cls.live:
        raise NotApplicable("not a live source")
    session = case.session()
    src = session.component
    assert isinstance(src, Source)
    failure: list[BaseException] = []

    def pump() -> None:
        try:
            session.start()
            for _ in src.messages():
                pass
        except BaseException as exc:  # reported below, in the test's thread
            failure.append(exc)

    thread = threading.Thread(target=pump, name=f"check-{case.cls.name}", daemon=True)
    thread.start()
    thread.join(0.3)
    src.stop()
    thread.join(STOP_WITHIN_S)
    if thread.is_alive():
        raise CheckFailed(f"{case.name}: messages() still running {STOP_WITHIN_S} s after "
                          f"stop()")
    if failure:
        raise CheckFailed(f"{case.name}: messages() raised {type(failure[0]).__name__}: "
                          f"{failure[0]}")


# -- hosts ------------------------------------------------------------------------------
def host_for(cls: type[Component]) -> type[Estimator] | None:
    """The first registered estimator (by name) that accepts constraint ``cls``."""
    if cls.kind != "constraint":
        return None
    from ..registry import default_registry
    for info in default_registry().by_kind()["estimator"]:
        if any(isinstance(cap, type) and issubclass(cls, cap) for cap in info.cls.accepts):
            return info.cls
    return None

