"""Conformance checks that built-in plugins are known to fail, and why.

Each entry is a finding handed to the plugin's owner. The conformance test requires
every :data:`KNOWN` entry to still fail on the bundled sample (a fixed plugin fails the
test until its entry is deleted here); a plugin's own tests, which run the suite on
their own sample, leave out exactly these checks through :func:`known`.
"""
from __future__ import annotations

#: (kind, name) -> {check: why it fails}
KNOWN: dict[tuple[str, str], dict[str, str]] = {
}

#: Failures the bundled sample does not provoke but a plugin's own test sample does
#: (these are not required to fail on the bundled sample).
KNOWN_WITH_OWN_SAMPLE: dict[tuple[str, str], dict[str, str]] = {
}


def known(kind: str, name: str) -> tuple[str, ...]:
    """The checks plugin ``name`` of ``kind`` is known to fail (for ``exclude=``)."""
    return tuple({**KNOWN.get((kind, name), {}), **KNOWN_WITH_OWN_SAMPLE.get((kind, name), {})})
