"""Parameter tables generated from a plugin's pydantic model (CLI listing and docs).

Parameter groups (nested models) are listed member by member under dotted names
(``detector.window``), the names ``--set estimators.ins.detector.window=0.03`` uses.
Angles are shown in radians, the unit the plugin reads, and in degrees beside them.
"""
from __future__ import annotations

import math
import textwrap
import types
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
    if origin is typing.Annotated:            # Angle, AngularRate: a float with a unit parser
        return type_name(typing.get_args(annotation)[0])
    if origin is typing.Literal:
        return "one of: " + ", ".join(str(a) for a in typing.get_args(annotation))
    if origin in (typing.Union, types.UnionType):
        args = [type_name(a) for a in typing.get_args(annotation)]
        return " or ".join("none" if a == "NoneType" else a for a in args)
    if origin is not None:
        args = ", ".join(type_name(a) for a in typing.get_args(annotation))
        return f"{getattr(origin, '__name__', str(origin))}[{args}]"
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return f"mapping ({annotation.__name__})"
    return getattr(annotation, "__name__", str(annotation))


def nested_model(annotation: object) -> type[BaseModel] | None:
    """The parameter group (a pydantic model) an annotation holds, alone or with None."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    if typing.get_origin(annotation) in (typing.Union, types.UnionType):
        models = [a for a in typing.get_args(annotation) if a is not type(None)]
        if len(models) == 1:
            return nested_model(models[0])
    return None


def fields_at(model: type[BaseModel], loc: tuple) -> list[str]:
    """Parameter names of the group at ``loc`` (a pydantic error location) in ``model``:
    what an unknown key there could have been."""
    for key in loc:
        field = model.model_fields.get(key) if isinstance(key, str) else None
        group = nested_model(field.annotation) if field is not None else None
        if group is None:
            break
        model = group
    return list(model.model_fields)


#: Units whose values are also shown in degrees, with the degree unit they turn into.
_DEGREE_UNITS = {"rad": "deg", "rad/s": "deg/s", "rad/m": "deg/m"}


def _show(value: object, unit: str) -> str:
    """A default as the table shows it: floats to 6 significant digits, angles also in
    degrees."""
    if not isinstance(value, float):
        return repr(value)
    text = f"{value:.6g}"
    text += "" if any(c in text for c in ".ein") else ".0"
    if unit in _DEGREE_UNITS:
        text += f" ({math.degrees(value):.4g} {_DEGREE_UNITS[unit]})"
    return text


def param_rows(model: type[BaseModel], prefix: str = "",
               defaults: BaseModel | None = None) -> list[ParamRow]:
    """One row per parameter of ``model``; a parameter group (nested model) gives a row
    of its own followed by its members as ``group.member``, whose defaults are those of
    the group's default value (``defaults``) where it has one."""
    rows = []
    for name, f in model.model_fields.items():
        extra = f.json_schema_extra if isinstance(f.json_schema_extra, dict) else {}
        unit = str(extra.get("unit", "") or "")
        bounds = []
        for meta in f.metadata:
            for cls, attr, sym in _BOUNDS:
                if isinstance(meta, cls):
                    bounds.append(f"{sym} {getattr(meta, attr)}")
        if defaults is not None:
            value = getattr(defaults, name)
            default = _show(value, unit)
        elif f.is_required():
            value, default = PydanticUndefined, "(required)"
        else:
            value = f.get_default(call_default_factory=True)
            default = _show(value, unit)
        meaning = " ".join((f.description or "").split())
        if bounds:
            meaning += f" [{', '.join(bounds)}]"
        group = nested_model(f.annotation)
        if group is not None:
            rows.append(ParamRow(prefix + name, "group", "" if value is not None else "None",
                                 "", meaning.strip()))
            rows += param_rows(group, f"{prefix}{name}.",
                               value if isinstance(value, BaseModel) else None)
            continue
        rows.append(ParamRow(prefix + name, type_name(f.annotation), default, unit,
                             meaning.strip()))
    return rows


def format_table(rows: list[list[str]], headers: list[str],
                 wrap: dict[int, int] | None = None) -> str:
    """Aligned columns; column ``i`` in ``wrap`` is wrapped at ``wrap[i]`` characters onto
    continuation lines."""
    wrap = wrap or {}
    cells = [[textwrap.wrap(c, wrap[i]) or [""] if i in wrap else [c] for i, c in enumerate(r)]
             for r in rows]
    widths = [max([len(h)] + [len(line) for r in cells for line in r[i]])
              for i, h in enumerate(headers)]
    out = ["  ".join(h.ljust(w) for h, w in zip(headers, widths)).rstrip(),
           "  ".join("-" * w for w in widths)]
    for r in cells:
        for k in range(max(len(c) for c in r)):
            line = [c[k] if k < len(c) else "" for c in r]
            out.append("  ".join(c.ljust(w) for c, w in zip(line, widths)).rstrip())
    return "\n".join(out)
