"""Safe YAML loading that remembers where every value came from (file:line:col).

The document is composed with :class:`yaml.SafeLoader` (no Python object tags, no
imports) and converted to plain data while recording the start mark of each node
under its path, e.g. ``("estimators", 0, "particles") -> (12, 5)``. Validation
errors found later by path can then point at the exact place in the file.

Limits, so that no file can make reading it hang or exhaust memory (each refusal is a
located :class:`ConfigError`): a file of at most :data:`MAX_BYTES` (read no further;
only regular files, so ``/dev/zero`` or a pipe is refused), nesting at most
:data:`MAX_DEPTH` levels deep, at most :data:`MAX_NODES` values once aliases are
expanded (a "billion laughs" file of nine lines expands to 10^9), and no alias
inside its own anchor (a recursive structure).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

Path_ = tuple[str | int, ...]

#: Largest YAML file read [bytes] (pipelines, scenarios and calibrations are a few kB).
MAX_BYTES = 4 * 1024 * 1024
#: Deepest nesting of mappings and lists, aliases expanded.
MAX_DEPTH = 64
#: Most values (scalars, mappings, lists) in a document, aliases expanded.
MAX_NODES = 200_000


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
    if len(text) > MAX_BYTES:
        raise ConfigError([Problem(file, None, None, "", f"larger than {MAX_BYTES} bytes: "
                                   "not a pipeline or configuration file")])
    loader = yaml.SafeLoader(text)
    try:
        _check_depth(text)
        node = loader.get_single_node()
        marks: dict[Path_, tuple[int, int]] = {}
        if node is not None:
            _check_expansion(node, 1, {}, set())
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


def _limit(mark: yaml.Mark, message: str) -> ConfigError:
    return ConfigError([Problem("", mark.line + 1, mark.column + 1, "", message)])


def _check_depth(text: str) -> None:
    """Refuse nesting deeper than :data:`MAX_DEPTH` before composing (the composer
    recurses once per level)."""
    depth = 0
    for event in yaml.parse(text, Loader=yaml.SafeLoader):
        if isinstance(event, (yaml.MappingStartEvent, yaml.SequenceStartEvent)):
            depth += 1
            if depth > MAX_DEPTH:
                raise _limit(event.start_mark, f"nested more than {MAX_DEPTH} levels deep")
        elif isinstance(event, (yaml.MappingEndEvent, yaml.SequenceEndEvent)):
            depth -= 1


def _check_expansion(node: yaml.Node, depth: int, memo: dict[int, tuple[int, int]],
                     active: set[int]) -> tuple[int, int]:
    """(values, levels) under ``node`` with aliases expanded; raises past the limits.

    Each node is measured once (``memo``), so a file of nested aliases costs its own
    size, not its expansion; ``active`` holds the nodes being measured (an alias to one
    of them is recursive).
    """
    if depth > MAX_DEPTH:
        raise _limit(node.start_mark, f"nested more than {MAX_DEPTH} levels deep once "
                     "aliases are expanded")
    known = memo.get(id(node))
    if known is not None:
        if depth + known[1] - 1 > MAX_DEPTH:
            raise _limit(node.start_mark, f"nested more than {MAX_DEPTH} levels deep once "
                         "aliases are expanded")
        return known
    if isinstance(node, yaml.ScalarNode):
        return 1, 1
    if id(node) in active:
        raise _limit(node.start_mark, "an alias refers to the value it is part of "
                     "(a recursive structure)")
    active.add(id(node))
    children = ([n for pair in node.value for n in pair] if isinstance(node, yaml.MappingNode)
                else node.value)
    size, height = 1, 1
    for child in children:
        s, h = _check_expansion(child, depth + 1, memo, active)
        size, height = size + s, max(height, h + 1)
        if size > MAX_NODES:
            raise _limit(node.start_mark, f"more than {MAX_NODES} values once aliases "
                         "are expanded (an alias bomb?)")
    active.discard(id(node))
    memo[id(node)] = (size, height)
    return size, height


def load(path: str | Path) -> LocatedDocument:
    """Read and parse a YAML file (see :func:`loads`; at most :data:`MAX_BYTES` are read)."""
    path = Path(path)
    try:
        if path.exists() and not path.is_file():
            raise ConfigError([Problem(str(path), None, None, "", "cannot read: not a "
                                       "regular file")])
        with open(path, "rb") as fh:
            raw = fh.read(MAX_BYTES + 1)
    except OSError as exc:
        raise ConfigError([Problem(str(path), None, None, "", f"cannot read: {exc.strerror}")]) from None
    if len(raw) > MAX_BYTES:
        raise ConfigError([Problem(str(path), None, None, "", f"larger than {MAX_BYTES} "
                                   "bytes: not a pipeline or configuration file")])
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ConfigError([Problem(str(path), None, None, "", f"not UTF-8 text: {exc}")]) from None
    return loads(text, str(path))
