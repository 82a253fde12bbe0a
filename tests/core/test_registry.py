"""Plugin discovery: entry points, broken packages, misspelled hooks, bad classes."""
from __future__ import annotations

import importlib.metadata as md
import textwrap

from firenav_framework.registry import default_registry, load_registry


def make_module(tmp_path, monkeypatch, name: str, source: str) -> md.EntryPoint:
    (tmp_path / f"{name}.py").write_text(textwrap.dedent(source))
    monkeypatch.syspath_prepend(str(tmp_path))
    return md.EntryPoint(name=name, value=name, group="firenav")


GOOD = """
from firenav_framework import Sensor, Params, Range, hookimpl
class Good(Sensor):
    '''A good sensor.'''
    name = "good_sensor"
    inputs = (Range,)
    outputs = {"range": Range}
    class Params(Params):
        pass
    def handle(self, stream, msg):
        self.ctx.publish("range", msg)
@hookimpl
def firenav_plugins():
    return [Good]
"""


def test_builtin_plugins_register_through_entry_points():
    reg = default_registry()
    info = reg.get("sink", "csv_tracks")
    assert info is not None and info.package == "firenav"
    assert info.summary.startswith("Write pose estimates as CSV")
    assert not reg.errors, reg.errors


def test_a_broken_package_is_reported_and_the_others_still_load(tmp_path, monkeypatch):
    good = make_module(tmp_path, monkeypatch, "good_pkg", GOOD)
    broken = make_module(tmp_path, monkeypatch, "broken_pkg", "raise RuntimeError('boom')\n")
    reg = load_registry([broken, good])
    assert reg.get("sensor", "good_sensor") is not None
    (err,) = reg.errors
    assert "broken_pkg" in err and "RuntimeError: boom" in err


def test_a_misspelled_hook_is_reported_not_silently_ignored(tmp_path, monkeypatch):
    typo = make_module(tmp_path, monkeypatch, "typo_pkg", """
        from firenav_framework import hookimpl
        @hookimpl
        def firenav_plugin():
            return []
        """)
    good = make_module(tmp_path, monkeypatch, "good_pkg2", GOOD)
    reg = load_registry([typo, good])
    assert reg.get("sensor", "good_sensor") is not None
    assert len(reg.errors) == 1 and "firenav_plugin" in reg.errors[0]


def test_bad_plugin_classes_and_name_clashes_are_reported(tmp_path, monkeypatch):
    bad = make_module(tmp_path, monkeypatch, "bad_pkg", GOOD.replace(
        "return [Good]", "return [Good, Good, object, Nameless]").replace(
        "@hookimpl", "class Nameless(Sensor):\n    '''x'''\n@hookimpl"))
    reg = load_registry([bad])
    assert reg.get("sensor", "good_sensor") is not None
    assert len(reg.errors) == 3
    assert any("already provided" in e for e in reg.errors)
    assert any("is not a firenav component class" in e for e in reg.errors)
    assert any("needs a `name`" in e for e in reg.errors)


def test_a_hook_that_raises_is_contained(tmp_path, monkeypatch):
    raising = make_module(tmp_path, monkeypatch, "raising_pkg", """
        from firenav_framework import hookimpl
        @hookimpl
        def firenav_plugins():
            raise KeyError("oops")
        """)
    good = make_module(tmp_path, monkeypatch, "good_pkg3", GOOD)
    reg = load_registry([raising, good])
    assert reg.get("sensor", "good_sensor") is not None
    assert any("raising_pkg" in e and "KeyError" in e for e in reg.errors)
