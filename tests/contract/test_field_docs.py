"""Parameter descriptions from attribute docstrings (firenav_framework.field_docs)."""
from __future__ import annotations

import importlib.util
import sys

from firenav_framework.field_docs import attribute_docstrings

MODULE = '''
from firenav_framework.contract import Params, param


class Radio(Params):
    """Two parameters."""

    gap: float = param(1.0, unit="s", gt=0)
    """a gap
    over two lines"""
    named: int = param(3, description="its own description")
    """not used"""


def make():
    class Local(Params):
        window: float = param(0.5, unit="s")
        """inside a function"""
    return Local


class Plugin:
    class Params(Params):
        rate: float = param(2.0, unit="Hz")
        """nested in a plugin class"""
'''


def _load(path, name, monkeypatch):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, name, module)
    spec.loader.exec_module(module)
    return module


def test_docstrings_describe_fields_however_the_module_was_imported(tmp_path, monkeypatch):
    """The same file under two module names (as a test harness or a vendor's copy may
    import it): pydantic's own frame lookup on Python < 3.13 loses the second's
    descriptions; these come from the class's own file."""
    path = tmp_path / "acme_params.py"
    path.write_text(MODULE)
    for name in ("acme_params_a", "acme_params_b"):
        module = _load(path, name, monkeypatch)
        fields = module.Radio.model_fields
        assert fields["gap"].description == "a gap\nover two lines"
        assert fields["named"].description == "its own description"
        assert module.make().model_fields["window"].description == "inside a function"
        assert module.Plugin.Params.model_fields["rate"].description == \
            "nested in a plugin class"
        schema = module.Radio.model_json_schema()["properties"]["gap"]
        assert schema["description"] == "a gap\nover two lines"
        assert schema["exclusiveMinimum"] == 0 and schema["unit"] == "s"


def test_a_class_without_source_keeps_only_explicit_descriptions():
    namespace: dict = {}
    exec(compile(MODULE, "<string>", "exec"), namespace)
    fields = namespace["Radio"].model_fields
    assert fields["gap"].description is None
    assert fields["named"].description == "its own description"
    assert attribute_docstrings(namespace["Radio"]) == {}
