"""Field descriptions from attribute docstrings: the string right below a model field.

    class Radio(DescribedModel):
        shadow_length: float = Field(1.0, gt=0)
        '''one range per fixed node per metre walked'''

The docstring becomes the field's ``description`` (what ``firenav plugins show`` and
the parameter-docs check read) unless the field names one itself; the field must be
declared with ``Field(...)`` or ``param(...)``. The source is found
from the class's module file and qualified name, one parse per file, so it does not
depend on how or from where the module was imported (pydantic's own
``use_attribute_docstrings`` looks for the defining frame on Python < 3.13, which fails
when the same file is known under two module names). A class without source (built
from a string) keeps its explicit descriptions only.
"""
from __future__ import annotations

import ast
import functools
import inspect
import os
import sys
from typing import Any

from pydantic import BaseModel
from pydantic.fields import FieldInfo

__all__ = ["DescribedModel", "attribute_docstrings"]


@functools.lru_cache(maxsize=256)
def _classes_of(path: str, mtime_ns: int) -> dict[str, dict[str, str]]:
    """Qualified class name -> {field: docstring} for every class in the file at ``path``
    (``mtime_ns`` keys the cache to the file's version)."""
    try:
        with open(path, encoding="utf-8") as f:
            tree = ast.parse(f.read(), filename=path)
    except (OSError, SyntaxError, UnicodeDecodeError):
        return {}
    out: dict[str, dict[str, str]] = {}

    def visit(body: list[ast.stmt], prefix: str) -> None:
        for node in body:
            if isinstance(node, ast.ClassDef):
                name = f"{prefix}{node.name}"
                out.setdefault(name, _docstrings(node.body))
                visit(node.body, f"{name}.")
            elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                visit(node.body, f"{prefix}{node.name}.<locals>.")
            elif isinstance(node, (ast.If, ast.Try, ast.With)):
                visit(getattr(node, "body", []) + getattr(node, "orelse", []), prefix)

    visit(tree.body, "")
    return out


def _docstrings(body: list[ast.stmt]) -> dict[str, str]:
    docs: dict[str, str] = {}
    for prev, node in zip(body, body[1:]):
        if (isinstance(prev, ast.AnnAssign) and isinstance(prev.target, ast.Name)
                and isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant)
                and isinstance(node.value.value, str)):
            docs[prev.target.id] = inspect.cleandoc(node.value.value)
    return docs


def attribute_docstrings(cls: type) -> dict[str, str]:
    """{field name: docstring} of the attributes declared in ``cls``'s own body."""
    module = sys.modules.get(cls.__module__)
    path = getattr(module, "__file__", None)
    if not path or not path.endswith(".py"):
        return {}
    try:
        mtime = os.stat(path).st_mtime_ns
    except OSError:
        return {}
    return _classes_of(path, mtime).get(cls.__qualname__, {})


class DescribedModel(BaseModel):
    """A pydantic model whose fields take their descriptions from attribute docstrings."""

    def __init_subclass__(cls, **kwargs: Any) -> None:
        # before pydantic collects the fields: the descriptions enter its schema too
        own = cls.__dict__
        for name, doc in attribute_docstrings(cls).items():
            value = own.get(name)
            if isinstance(value, FieldInfo) and not value.description:
                setattr(cls, name, FieldInfo.merge_field_infos(value, description=doc))
        super().__init_subclass__(**kwargs)
