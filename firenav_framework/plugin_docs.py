"""Parameter tables generated from a plugin's pydantic model (CLI listing and docs)."""
from __future__ import annotations

import typing
from dataclasses import dataclass

import annotated_types as at
from pydantic import BaseModel
from pydantic_core import PydanticUndefined

_BOUNDS = ((at.Gt, "gt", ">"), (at.Ge, "ge", ">="), (at.Lt, "lt", "<"), (at.Le, "le", "<="),
           (at.MinLen, "min_length", "len >="), (at.MaxLen, "max_length", "len <="))


@dataclass(frozen=True)
class ParamRow:
    name: str
    type: str
    default: str
    unit: str
    meaning: str


def type_name(annotation: object) -> str:
    """Readable name of a type annotation: ``float``, ``one of: drop, keep``, ``list[str]``."""
    origin = typing.get_origin(annotation)
    if origin is typing.Literal:
        return "one of: " + ", ".join(str(a) for a in typing.get_args(annotation))
    if origin in (typing.Union, getattr(__import__("types"), "UnionType", None)):
        args = [type_name(a) for a in typing.get_args(annotation)]
        return " or ".join("none" if a == "NoneType" else a for a in args)
    if origin is not None:
        args = ", ".join(type_name(a) for a in typing.get_args(annotation))
        return f"{getattr(origin, '__name__', str(origin))}[{args}]"
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return f"mapping ({annotation.__name__})"
    return getattr(annotation, "__name__", str(annotation))


def param_rows(model: type[BaseModel]) -> list[ParamRow]:
    rows = []
    for name, f in model.model_fields.items():
        extra = f.json_schema_extra if isinstance(f.json_schema_extra, dict) else {}
        bounds = []
        for meta in f.metadata:
            for cls, attr, sym in _BOUNDS:
                if isinstance(meta, cls):
                    bounds.append(f"{sym} {getattr(meta, attr)}")
        if f.is_required():
            default = "(required)"
        elif f.default is PydanticUndefined or f.default_factory is not None:
            default = repr(f.get_default(call_default_factory=True))
        else:
            default = repr(f.default)
        meaning = f.description or ""
        if bounds:
            meaning += f" [{', '.join(bounds)}]"
        rows.append(ParamRow(name, type_name(f.annotation), default,
                             str(extra.get("unit", "") or ""), meaning.strip()))
    return rows


def format_table(rows: list[list[str]], headers: list[str]) -> str:
    widths = [max(len(h), *(len(r[i]) for r in rows)) if rows else len(h)
              for i, h in enumerate(headers)]
    out = ["  ".join(h.ljust(w) for h, w in zip(headers, widths)).rstrip(),
           "  ".join("-" * w for w in widths)]
    out += ["  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip() for r in rows]
    return "\n".join(out)
