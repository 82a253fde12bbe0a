"""``check_plugin``: every conformance check over one plugin class, in one call."""
from __future__ import annotations

import tempfile
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from pydantic import BaseModel

from ..contract import Component, Estimator
from ..messages import Message
from .checks import CHECKS, PASSED, CheckFailed, PluginCase, host_for, run_registered
from .harness import Recorder, validated
from .samples import sample_world

__all__ = ["check_plugin", "run_checks", "plugin_case", "ConformanceError", "PASSED"]


class ConformanceError(AssertionError):
    """One or more conformance checks failed; ``results`` has every check's outcome."""

    def __init__(self, cls: type, results: dict[str, Any]):
        self.results = results
        failed = {k: v for k, v in results.items() if isinstance(v, BaseException)}
        lines = [f"{cls.__name__} fails {len(failed)} of {len(results)} conformance checks:"]
        for name, exc in failed.items():
            text = str(exc) if isinstance(exc, CheckFailed) else f"{type(exc).__name__}: {exc}"
            lines.append(f"[{name}] {text}")
        super().__init__("\n".join(lines))


def plugin_case(cls: type[Component], params: dict | BaseModel | None = None, *,
                sample_input: Iterable[tuple[str, Message]] | None = None,
                building: Any = None, host: type[Estimator] | None = None,
                host_params: dict | BaseModel | None = None,
                faulty_params: Iterable[dict] = (), output_dir: Path | None = None,
                base_dir: Path | None = None, workdir: Path | None = None) -> PluginCase:
    """The :class:`~.checks.PluginCase` :func:`check_plugin` runs its checks on.

    Without ``sample_input``, a sensor, estimator, constraint or sink gets the messages
    of :func:`~.samples.sample_world` its inputs accept (a constraint: those of its host
    too) and that sample's building; ``building`` goes with a ``sample_input`` only.
    The checks' runs write into folders under ``workdir`` (default: a new temporary
    folder, left to the caller to remove).
    """
    host = host if host is not None else host_for(cls)
    if sample_input is None and cls.kind != "source":
        if building is not None:
            raise ValueError("a building goes with the sample_input that walks in it; "
                             "without sample_input the bundled sample brings its own")
        world = sample_world()
        types = [t for c in (cls, host) if c is not None for t in c.inputs]
        sample = [(s, m) for s, m in world.messages if types and isinstance(m, tuple(types))]
        building = world.building
    else:
        sample = list(sample_input or ())
    work = Path(workdir) if workdir is not None else Path(
        tempfile.mkdtemp(prefix=f"firenav-check-{cls.name or 'plugin'}-"))
    return PluginCase(cls=cls, params=validated(cls, params), sample=sample, building=building,
                      host=host if cls.kind == "constraint" else None, host_params=host_params,
                      faulty_params=list(faulty_params), output_dir=output_dir,
                      base_dir=base_dir, workdir=work)


def run_checks(case: PluginCase, checks: Iterable[str] | None = None,
               exclude: Iterable[str] = ()) -> dict[str, Any]:
    """Run ``checks`` (default: all of :data:`~.checks.CHECKS`, minus ``exclude``) on
    ``case``: check name -> ``"passed"``, ``"n/a: <why>"`` or the exception it raised
    (see :func:`~.checks.run_registered`)."""
    return run_registered(CHECKS, case, checks, exclude)


def check_plugin(cls: type[Component], params: dict | BaseModel | None = None, *,
                 sample_input: Iterable[tuple[str, Message]] | None = None,
                 building: Any = None, host: type[Estimator] | None = None,
                 host_params: dict | BaseModel | None = None,
                 faulty_params: Iterable[dict] = (), checks: Iterable[str] | None = None,
                 exclude: Iterable[str] = (), output_dir: Path | None = None,
                 base_dir: Path | None = None) -> Recorder:
    """Assert that ``cls`` conforms to the plugin contract; return what it published.

    The one call a plugin author puts in their own tests::

        from firenav_framework.testing import check_plugin

        def test_conforms():
            check_plugin(AcmeImu)                        # the bundled sample input
            check_plugin(AcmeImu, {"gain": 2.0}, sample_input=[("imu", block), ...])

    Every check of :mod:`firenav_framework.testing.checks` runs (the class, parameter
    docs, declared ports and ticks, ports, a constraint's capability, bad input,
    reset-then-refeed, determinism, a live source's stop); a failure of one does not
    stop the others, and the :class:`ConformanceError` raised lists them all. A class
    missing an abstract hook (a sensor without ``handle``) fails at once.

    Parameters
    ----------
    cls
        The plugin class.
    params
        Its parameters (a dict as in pipeline YAML, or a ``Params`` instance); default:
        every parameter at its default.
    sample_input
        ``(stream, message)`` pairs to feed it, in time order. Default: the messages of
        :func:`~firenav_framework.testing.sample_world` (a simulated team of two with
        every sensor) that its inputs accept, and that sample's building.
    building
        The building ``sample_input`` walks in, for plugins that need one (the bundled
        sample brings its own).
    host, host_params
        The estimator a constraint is attached to (default: the first registered
        estimator that accepts its capability).
    faulty_params
        For a source: parameter sets pointing at damaged data (a corrupt file, ...);
        each must run without raising and count or report the damage.
    checks, exclude
        Run only these checks / skip these (names of
        :data:`~firenav_framework.testing.checks.CHECKS`).
    output_dir
        Where the plain run on the sample writes its files (default: a temporary
        folder, as for the checks' other runs).
    base_dir
        Folder relative parameter paths are relative to (default: the working directory).

    Returns
    -------
    Recorder
        What the plugin published on the sample input (a source: what it yielded), for
        further assertions.
    """
    with tempfile.TemporaryDirectory(prefix=f"firenav-check-{cls.name or 'plugin'}-") as work:
        case = plugin_case(cls, params, sample_input=sample_input, building=building,
                           host=host, host_params=host_params, faulty_params=faulty_params,
                           output_dir=output_dir, base_dir=base_dir, workdir=Path(work))
        results = run_checks(case, checks, exclude)
        if any(isinstance(v, BaseException) for v in results.values()):
            raise ConformanceError(cls, results)
        if cls.kind == "source" and cls.live:
            return Recorder()
        return case.clean()[1]
