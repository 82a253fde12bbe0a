"""Every registered plugin passes the conformance suite (firenav_framework.testing).

Parametrised over the registry: a plugin registered under ``firenav.plugins`` (or a hook
module) is checked without anything to add here. tests/contract/cases.py gives the few
that need parameters to run (a file to replay, a loopback link); tests/contract/known.py
lists what built-in plugins are known to fail, each of which must still fail.
"""
from __future__ import annotations

import pytest

from firenav_framework.codecs import BUILTIN_CODECS, UnknownCodec, codec_names, get_codec
from firenav_framework.contract import KINDS
from firenav_framework.registry import default_registry
from firenav_framework.testing import ConformanceError, check_codec, plugin_case, run_checks

from . import cases
from .known import KNOWN

REGISTRY = default_registry()
PLUGINS = [(kind, name) for kind in KINDS for name in REGISTRY.names(kind)]

#: Checks that must run (not be "n/a") for every plugin of a kind: the sample input
#: has to exercise what the kind does.
MUST_RUN = {
    "source": ("ports", "deterministic"),
    "sensor": ("ports", "bad_input", "reset_refeed", "deterministic"),
    "estimator": ("ports", "bad_input", "reset_refeed", "deterministic"),
    "constraint": ("ports", "capability", "bad_input", "reset_refeed", "deterministic"),
    "sink": ("ports", "bad_input", "deterministic"),
}


def test_every_kind_has_built_in_plugins():
    assert {k for k, _ in PLUGINS} == set(KINDS)
    assert not REGISTRY.errors


@pytest.mark.parametrize("kind, name", PLUGINS, ids=[f"{k}.{n}" for k, n in PLUGINS])
def test_plugin_conforms(kind, name, tmp_path):
    info = REGISTRY.get(kind, name)
    assert info is not None, f"{kind} '{name}' is registered but does not load: {REGISTRY.errors}"
    cls = info.cls
    case = plugin_case(cls, workdir=tmp_path / "runs", **cases.setup(kind, name, tmp_path))
    results = run_checks(case)
    known = KNOWN.get((kind, name), {})
    failed = {k: v for k, v in results.items() if isinstance(v, BaseException)}
    unexpected = {k: v for k, v in failed.items() if k not in known}
    if unexpected:
        raise ConformanceError(cls, unexpected)
    fixed = sorted(set(known) - set(failed))
    assert not fixed, f"{kind} '{name}' now passes {fixed}: delete them from tests/contract/known.py"
    live = kind == "source" and cls.live
    must = ("live_stop",) if live else MUST_RUN[kind]
    skipped = {k: results[k] for k in must if k not in known and results[k] != "passed"}
    assert not skipped, f"{kind} '{name}': checks that did not run: {skipped}"


def test_every_registered_codec_conforms():
    """Codecs (built in, and entry points ``firenav.codecs``) one by one, on the sample
    input tests/contract/cases.py gives them; every built-in codec must have one."""
    failed = {}
    for name in codec_names():
        sample = cases.CODEC_SAMPLES.get(name)
        if sample is None and name in BUILTIN_CODECS:
            failed[name] = "no sample input in tests/contract/cases.py CODEC_SAMPLES"
            continue
        try:
            check_codec(get_codec(name), **(sample() if sample else {}))
        except (ConformanceError, UnknownCodec) as exc:
            failed[name] = str(exc)
    assert not failed, "\n".join(f"{k}: {v}" for k, v in failed.items())
