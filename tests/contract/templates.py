"""Loading a copy of a file of extension_templates/ as a module, the way a vendor starts."""
from __future__ import annotations

import importlib.util
import shutil
import sys
from pathlib import Path

from firenav_framework.codecs import Codec
from firenav_framework.contract import Component

TEMPLATES = Path(__file__).resolve().parents[2] / "extension_templates"
KINDS = ("source", "sensor", "estimator", "constraint", "sink")


def load(name: str, tmp_path: Path) -> type:
    """The plugin (or codec) class of a copy of ``extension_templates/<name>.py``."""
    copy = tmp_path / f"copied_{name}.py"
    shutil.copy(TEMPLATES / f"{name}.py", copy)
    spec = importlib.util.spec_from_file_location(copy.stem, copy)
    module = importlib.util.module_from_spec(spec)
    sys.modules[copy.stem] = module
    try:
        spec.loader.exec_module(module)
    finally:
        del sys.modules[copy.stem]
    base = Codec if name == "codec" else Component
    (cls,) = [v for v in vars(module).values() if isinstance(v, type) and issubclass(v, base)
              and v.__module__ == module.__name__]
    return cls
