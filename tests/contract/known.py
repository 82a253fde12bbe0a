"""Conformance checks that built-in plugins are known to fail, and why.

Each entry is a finding handed to the plugin's owner. The conformance test requires
every :data:`KNOWN` entry to still fail on the bundled sample (a fixed plugin fails the
test until its entry is deleted here); a plugin's own tests, which run the suite on
their own sample, leave out exactly these checks through :func:`known`.
"""
from __future__ import annotations

#: (kind, name) -> {check: why it fails}
KNOWN: dict[tuple[str, str], dict[str, str]] = {
    ("sensor", "rfid_reader"): {
        "reset_refeed": "tags a firefighter deployed are kept through reset(agent) (they "
                        "are on the doors), so the same deployment again is a duplicate: "
                        "decide whether reset forgets them",
    },
    ("estimator", "zupt_ins"): {
        "parameter_docs": "gravity.latitude_deg is in degrees; odometry.length_sigma has no unit",
    },
    ("estimator", "dead_reckoning"): {
        "parameter_docs": "step_noise.length_sigma has no unit (a fraction of the step: unit='1')",
    },
    ("estimator", "pdr_ekf"): {
        "parameter_docs": "process.heading_turn_noise has no unit (rad per rad turned)",
    },
}

#: Failures the bundled sample does not provoke but a plugin's own test sample does
#: (these are not required to fail on the bundled sample).
KNOWN_WITH_OWN_SAMPLE: dict[tuple[str, str], dict[str, str]] = {
    ("sensor", "rfid_reader"): {
        "bad_input": "a read older than the last one of its pass changes the pass and is "
                     "not counted",
    },
}


def known(kind: str, name: str) -> tuple[str, ...]:
    """The checks plugin ``name`` of ``kind`` is known to fail (for ``exclude=``)."""
    return tuple({**KNOWN.get((kind, name), {}), **KNOWN_WITH_OWN_SAMPLE.get((kind, name), {})})
