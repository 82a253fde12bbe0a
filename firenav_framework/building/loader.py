"""``load_building``: one entry point for every plan format, chosen by suffix and content."""
from __future__ import annotations

import json
from pathlib import Path

from .model import Building, BuildingError

__all__ = ["load_building"]


def load_building(path: str | Path, layer_map: str | Path | None = None) -> Building:
    """Load a plan: native GeoJSON, Aamks JSON (static or CAD export) or DXF.

    ``.geojson`` is the native format; ``.json`` is recognised by content (a GeoJSON
    FeatureCollection, an Aamks ``*.static.json`` / ``*.cad.json`` export, or an ORCA-style
    ``{"obstacles": ...}`` file); ``.dxf`` uses ``layer_map`` (YAML), else a
    ``<plan>.layers.yaml`` sidecar, else the built-in layer table. Invalid plans raise
    :class:`BuildingError` naming the file and the feature.
    """
    path = Path(path)
    if not path.is_file():
        raise BuildingError(f"{path}: no such plan file")
    suffix = path.suffix.lower()
    if suffix == ".dxf":
        from .dxf import read_dxf
        return read_dxf(path, layer_map)
    if layer_map is not None:
        raise BuildingError(f"{path}: a layer map only applies to DXF plans")
    if suffix not in (".geojson", ".json"):
        raise BuildingError(f"{path}: unknown plan format {suffix!r} "
                            "(expected .geojson, .json (Aamks) or .dxf)")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise BuildingError(f"{path}: not valid JSON ({exc})") from None
    if suffix == ".geojson" or (isinstance(data, dict) and data.get("type") == "FeatureCollection"):
        from .geojson_format import parse_geojson
        return parse_geojson(data, where=str(path), source=path, default_name=path.stem)
    from .aamks import is_aamks, parse_aamks
    if is_aamks(data):
        return parse_aamks(data, where=str(path), source=path, default_name=path.stem)
    raise BuildingError(f"{path}: not a firenav plan (GeoJSON FeatureCollection) nor an "
                        "Aamks export (floors/obstacles)")
