"""``load_building``: one entry point for every plan format, chosen by suffix and content."""
from __future__ import annotations

import json
from pathlib import Path

from .limits import check_file_size
from .model import Building, BuildingError

__all__ = ["load_building", "read_plan_json", "plan_problem"]


def read_plan_json(path: Path):
    """Decoded JSON of a plan file within :data:`~.limits.MAX_PLAN_BYTES`; any problem
    (unreadable, not UTF-8, not JSON, nested too deeply, a number too long) is a
    :class:`BuildingError` naming the file."""
    check_file_size(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise BuildingError(f"{path}: cannot read the plan ({exc.strerror})") from None
    except UnicodeDecodeError as exc:
        raise BuildingError(f"{path}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None
    try:
        return json.loads(text)
    except RecursionError:
        raise BuildingError(f"{path}: not a plan: JSON nested too deeply") from None
    except ValueError as exc:  # JSONDecodeError, or an integer too long to convert
        raise BuildingError(f"{path}: not valid JSON ({exc})") from None


def load_building(path: str | Path, layer_map: str | Path | None = None) -> Building:
    """Load a plan: native GeoJSON, Aamks JSON (static or CAD export) or DXF.

    ``.geojson`` is the native format; ``.json`` is recognised by content (a GeoJSON
    FeatureCollection, an Aamks ``*.static.json`` / ``*.cad.json`` export, or an ORCA-style
    ``{"obstacles": ...}`` file); ``.dxf`` uses ``layer_map`` (YAML), else a
    ``<plan>.layers.yaml`` sidecar, else the built-in layer table. Invalid plans raise
    :class:`BuildingError` naming the file and the feature.
    """
    path = Path(path)
    if not path.exists():
        raise BuildingError(f"{path}: no such plan file")
    check_file_size(path)
    suffix = path.suffix.lower()
    if suffix == ".dxf":
        from .dxf import read_dxf
        return read_dxf(path, layer_map)
    if layer_map is not None:
        raise BuildingError(f"{path}: a layer map only applies to DXF plans")
    if suffix not in (".geojson", ".json"):
        raise BuildingError(f"{path}: unknown plan format {suffix!r} "
                            "(expected .geojson, .json (Aamks) or .dxf)")
    data = read_plan_json(path)
    if suffix == ".geojson" or (isinstance(data, dict) and data.get("type") == "FeatureCollection"):
        from .geojson_format import parse_geojson
        return parse_geojson(data, where=str(path), source=path, default_name=path.stem)
    from .aamks import is_aamks, parse_aamks
    if is_aamks(data):
        return parse_aamks(data, where=str(path), source=path, default_name=path.stem)
    raise BuildingError(f"{path}: not a firenav plan (GeoJSON FeatureCollection) nor an "
                        "Aamks export (floors/obstacles)")


def plan_problem(path: str | Path) -> str | None:
    """Why the plan at ``path`` cannot be used (it is loaded once to find out), or None;
    for validators that report it at the line naming the plan."""
    try:
        load_building(path)
    except BuildingError as exc:
        return f"the building plan cannot be loaded: {exc}"
    return None
