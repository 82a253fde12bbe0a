"""The import contract (tests/contract/import_rules.py) holds on our tree, and the checker
finds every kind of forbidden import in a tree built to break it."""
from __future__ import annotations

import textwrap
from pathlib import Path

import pytest

from .import_rules import RULES, module_name, report, violations

REPO = Path(__file__).resolve().parents[2]

#: Known violations being removed on another branch of the same migration, as
#: (path, imported module). Each must still occur: a fixed one fails the test below
#: until it is deleted here, so the list can only shrink.
KNOWN: set[tuple[str, str]] = set()


def test_our_tree_keeps_the_import_contract():
    found = violations(REPO)
    new = [v for v in found if (v.path, v.imported) not in KNOWN]
    assert not new, report(new)
    stale = KNOWN - {(v.path, v.imported) for v in found}
    assert not stale, f"no longer imported, delete from KNOWN: {sorted(stale)}"


def _tree(root: Path, files: dict[str, str]) -> Path:
    for rel, text in files.items():
        path = root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(textwrap.dedent(text))
    return root


def test_every_forbidden_form_is_found_and_listed_with_its_place(tmp_path):
    root = _tree(tmp_path, {
        "firenav_framework/__init__.py": "",
        "firenav_framework/transports/__init__.py": "",
        "firenav_framework/transports/player.py": """\
            import numpy as np
            from firenav_plugins.sensors.imu_can import encode

            def lazy():
                import firenav_plugins.sensors.uwb
            """,
        "firenav_framework/registry.py": """\
            import importlib
            mod = importlib.import_module("firenav_plugins.estimators.zupt_ins")
            ok = importlib.import_module(name_from_entry_point)
            """,
        "plugins/__init__.py": "",
        "plugins/constraints/__init__.py": "",
        "plugins/constraints/orca/__init__.py": "",
        "plugins/constraints/orca/constraint.py": """\
            from typing import TYPE_CHECKING
            from ..wall_crossing import helper
            from firenav_framework.capabilities import OdometryCorrection
            if TYPE_CHECKING:
                from ...estimators.dead_reckoning import DeadReckoning
            """,
        "plugins/constraints/wall_crossing.py": "from firenav_plugins import estimators\n",
        "plugins/sensors/__init__.py": "",
        "plugins/sensors/foot_imu.py": "from ..estimators.zupt_ins import screen\n",
        "plugins/sensors/uwb.py": "from firenav_framework.codecs import get_codec\n",
        "plugins/estimators/__init__.py": "",
        "plugins/estimators/pf.py": "from ..constraints.orca import constraint\n",
    })
    found = violations(root)
    assert [(v.path, v.line, v.imported) for v in found] == [
        ("firenav_framework/registry.py", 2, "firenav_plugins.estimators.zupt_ins"),
        ("firenav_framework/transports/player.py", 2, "firenav_plugins.sensors.imu_can"),
        ("firenav_framework/transports/player.py", 5, "firenav_plugins.sensors.uwb"),
        ("plugins/constraints/orca/constraint.py", 5, "firenav_plugins.estimators.dead_reckoning"),
        ("plugins/constraints/wall_crossing.py", 1, "firenav_plugins.estimators"),
        ("plugins/sensors/foot_imu.py", 1, "firenav_plugins.estimators.zupt_ins"),
    ]
    text = report(found)
    assert text.startswith("6 forbidden import(s):")
    assert ("plugins/sensors/foot_imu.py:1 imports firenav_plugins.estimators.zupt_ins "
            "(a sensor publishes measurements") in text
    assert "the core never imports a plugin" in text
    assert report(violations(root, [r for r in RULES if r.importer == "firenav_plugins.sensors"])
                  ).startswith("1 forbidden import(s)")


def test_a_clean_tree_has_nothing_to_report(tmp_path):
    root = _tree(tmp_path, {"firenav_framework/a.py": "from .b import c\n",
                            "plugins/constraints/x.py": "from ..sensors import y\n"})
    assert violations(root) == [] and report([]) == ""


@pytest.mark.parametrize("rel, name", [
    ("firenav_framework/__init__.py", "firenav_framework"),
    ("firenav_framework/codecs/base.py", "firenav_framework.codecs.base"),
    ("plugins/constraints/orca/__init__.py", "firenav_plugins.constraints.orca"),
    ("tests/core/toys.py", None),
])
def test_module_names_follow_the_installed_layout(rel, name):
    assert module_name(Path("/r") / rel, Path("/r")) == name
