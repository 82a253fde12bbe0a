"""The import contract of the source tree, checked by walking every module's AST.

A rule forbids the modules under one folder to import the modules of a package; the
modules are read, never imported, so a broken module cannot hide its imports. Every
``import``/``from ... import`` counts (inside functions and ``TYPE_CHECKING`` blocks
too: a lazy import is still a dependency), relative imports resolved against the
module's own package, and so do literal names given to ``importlib.import_module``.

The ``plugins/`` folder is installed as the package ``firenav_plugins`` (setup.py), so
a module's import name is its path with that prefix renamed.
"""
from __future__ import annotations

import ast
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path

#: folder in the repository -> import name of the package it holds
PACKAGE_ROOTS = {"firenav_framework": "firenav_framework", "plugins": "firenav_plugins"}


@dataclass(frozen=True)
class Rule:
    """Modules whose name starts with ``importer`` must not import ``forbidden``."""

    importer: str
    forbidden: str
    why: str


@dataclass(frozen=True)
class Violation:
    """One forbidden import: where it is, what it imports and the rule it breaks."""

    path: str
    line: int
    imported: str
    rule: Rule

    def __str__(self) -> str:
        return f"{self.path}:{self.line} imports {self.imported} ({self.rule.why})"


RULES = (
    Rule("firenav_framework", "firenav_plugins",
         "the core never imports a plugin: plugins are found through the registry"),
    Rule("firenav_plugins.constraints", "firenav_plugins.estimators",
         "a constraint speaks a capability of firenav_framework.capabilities, never an "
         "estimator's module"),
    Rule("firenav_plugins.sensors", "firenav_plugins.estimators",
         "a sensor publishes measurements; it never depends on who consumes them"),
)


def module_name(path: Path, root: Path) -> str | None:
    """Import name of the module at ``path`` (None outside :data:`PACKAGE_ROOTS`)."""
    rel = path.relative_to(root).with_suffix("")
    top = PACKAGE_ROOTS.get(rel.parts[0])
    if top is None:
        return None
    parts = [top, *rel.parts[1:]]
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def imported_names(tree: ast.AST, module: str, is_package: bool) -> Iterator[tuple[int, str]]:
    """(line, absolute module name) of every import in ``tree``.

    ``from pkg import name`` yields ``pkg.name`` too, since ``name`` may be a module.
    """
    package = module if is_package else module.rpartition(".")[0]
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield node.lineno, alias.name
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")
                anchor = anchor[:len(anchor) - (node.level - 1)]
                base = ".".join([*anchor, *([base] if base else [])])
            yield node.lineno, base
            for alias in node.names:
                if alias.name != "*":
                    yield node.lineno, f"{base}.{alias.name}"
        elif (isinstance(node, ast.Call) and _is_import_call(node.func) and node.args
              and isinstance(node.args[0], ast.Constant) and isinstance(node.args[0].value, str)):
            yield node.lineno, node.args[0].value


def _is_import_call(func: ast.expr) -> bool:
    if isinstance(func, ast.Attribute):
        return func.attr == "import_module"
    return isinstance(func, ast.Name) and func.id in ("import_module", "__import__")


def _within(name: str, package: str) -> bool:
    return name == package or name.startswith(package + ".")


def source_files(root: Path) -> Iterator[Path]:
    """Every ``.py`` file of the packages under ``root``."""
    for folder in PACKAGE_ROOTS:
        yield from sorted((root / folder).rglob("*.py"))


def violations(root: Path, rules: Iterable[Rule] = RULES) -> list[Violation]:
    """Every import under ``root`` that breaks one of ``rules``, in file order."""
    rules = tuple(rules)
    found: list[Violation] = []
    for path in source_files(root):
        module = module_name(path, root)
        applicable = [r for r in rules if module and _within(module, r.importer)]
        if not applicable:
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        seen: set[tuple[int, str]] = set()
        for line, name in imported_names(tree, module, path.name == "__init__.py"):
            for rule in applicable:
                if _within(name, rule.forbidden) and (line, rule.forbidden) not in seen:
                    seen.add((line, rule.forbidden))
                    found.append(Violation(path.relative_to(root).as_posix(), line, name, rule))
    return found


def report(found: Iterable[Violation]) -> str:
    """The offending imports, one per line, for an assertion message."""
    lines = [str(v) for v in found]
    return f"{len(lines)} forbidden import(s):\n  " + "\n  ".join(lines) if lines else ""
