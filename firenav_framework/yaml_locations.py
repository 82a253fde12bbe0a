"""Safe YAML loading that remembers where every value came from (file:line:col).

The document is composed with :class:`yaml.SafeLoader` (no Python object tags, no
imports) and converted to plain data while recording the start mark of each node
under its path, e.g. ``("estimators", 0, "particles") -> (12, 5)``. Validation
errors found later by path can then point at the exact place in the file.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

Path_ = tuple[str | int, ...]


class ConfigError(Exception):
    """A problem in a configuration file, with its location. ``problems`` lists all."""

    def __init__(self, problems: list["Problem"]):
        self.problems = problems
        super().__init__("\n".join(str(p) for p in problems))


@dataclass(frozen=True)
class Problem:
    """One message about a place in a file: ``file:line:col: where: message``."""

    file: str
    line: int | None
    col: int | None
    where: str
    message: str

    def __str__(self) -> str:
        loc = self.file
        if self.line is not None:
            loc += f":{self.line}:{self.col}"
        return f"{loc}: {self.where + ': ' if self.where else ''}{self.message}"


def format_path(path: Path_) -> str:
    """``("estimators", 0, "particles")`` -> ``estimators[0].particles``."""
    out = ""
    for part in path:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            out += ("." if out else "") + str(part)
    return out


@dataclass
class LocatedDocument:
    """Plain data from a YAML file plus the location of each node by path."""

    data: Any
    file: str
    marks: dict[Path_, tuple[int, int]] = field(default_factory=dict)

    def locate(self, path: Path_) -> tuple[int | None, int | None]:
        """Line and column (1-based) of the deepest node of ``path`` that exists."""
        path = tuple(path)
        while path not in self.marks and path:
            path = path[:-1]
        return self.marks.get(path, (None, None))

    def problem(self, path: Path_, message: str) -> Problem:
        line, col = self.locate(path)
        return Problem(self.file, line, col, format_path(path), message)


_PLAIN_TAGS = {yaml.MappingNode: "tag:yaml.org,2002:map",
               yaml.SequenceNode: "tag:yaml.org,2002:seq"}


def _convert(loader: yaml.SafeLoader, node: yaml.Node, path: Path_,
             marks: dict[Path_, tuple[int, int]]) -> Any:
    marks[path] = (node.start_mark.line + 1, node.start_mark.column + 1)
    expected = _PLAIN_TAGS.get(type(node))
    if expected is not None and node.tag != expected:  # the safe constructor only checks scalars
        raise ConfigError([Problem("", *marks[path], format_path(path),
                                   f"unsupported YAML tag '{node.tag}'; only plain YAML is read")])
    if isinstance(node, yaml.MappingNode):
        loader.flatten_mapping(node)  # resolves YAML merge keys (<<)
        out: dict[Any, Any] = {}
        for key_node, value_node in node.value:
            key = loader.construct_object(key_node, deep=True)
            if not isinstance(key, (str, int, float, bool)):
                raise ConfigError([Problem(
                    "", key_node.start_mark.line + 1, key_node.start_mark.column + 1,
                    format_path(path), f"mapping keys must be plain values, not {key!r}")])
            if key in out:
                raise ConfigError([Problem(
                    "", key_node.start_mark.line + 1, key_node.start_mark.column + 1,
                    format_path(path + (key,)), "key appears twice in the same mapping")])
            out[key] = _convert(loader, value_node, path + (key,), marks)
            marks[path + (key,)] = (key_node.start_mark.line + 1,
                                    key_node.start_mark.column + 1)
        return out
    if isinstance(node, yaml.SequenceNode):
        return [_convert(loader, item, path + (i,), marks) for i, item in enumerate(node.value)]
    return loader.construct_object(node, deep=True)


def loads(text: str, file: str = "<string>") -> LocatedDocument:
    """Parse YAML text safely; syntax errors become a :class:`ConfigError` with location."""
    loader = yaml.SafeLoader(text)
    try:
        node = loader.get_single_node()
        marks: dict[Path_, tuple[int, int]] = {}
        data = None if node is None else _convert(loader, node, (), marks)
    except ConfigError as exc:
        raise ConfigError([Problem(file, p.line, p.col, p.where, p.message)
                           for p in exc.problems]) from None
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line, col = (mark.line + 1, mark.column + 1) if mark else (None, None)
        what = " ".join(x for x in (exc.context, exc.problem) if x)
        kind = ("unsupported YAML (only plain YAML is read)"
                if isinstance(exc, yaml.constructor.ConstructorError) else "YAML syntax error")
        raise ConfigError([Problem(file, line, col, "", f"{kind}: {what}")]) from None
    except yaml.YAMLError as exc:
        raise ConfigError([Problem(file, None, None, "", f"YAML error: {exc}")]) from None
    finally:
        loader.dispose()
    return LocatedDocument(data=data, file=file, marks=marks)


def load(path: str | Path) -> LocatedDocument:
    """Read and parse a YAML file (see :func:`loads`)."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise ConfigError([Problem(str(path), None, None, "", f"cannot read: {exc.strerror}")]) from None
    except UnicodeDecodeError as exc:
        raise ConfigError([Problem(str(path), None, None, "", f"not UTF-8 text: {exc}")]) from None
    return loads(text, str(path))
