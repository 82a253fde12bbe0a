"""The plans shipped with firenav, as native GeoJSON package data.

Names: flat_125, area_250, office_loop, corridor, three_storey (what each models, and
the code that draws them, is in :mod:`.plans`).
"""
from __future__ import annotations

from pathlib import Path

from .model import BuildingError

__all__ = ["bundled_plans", "bundled_plan", "DATA_DIR"]

DATA_DIR = Path(__file__).with_name("data")


def bundled_plans() -> list[str]:
    """Names of the bundled plans (sorted)."""
    return sorted(p.stem for p in DATA_DIR.glob("*.geojson"))


def bundled_plan(name: str) -> Path:
    """Path of a bundled plan's native GeoJSON file."""
    path = DATA_DIR / f"{name}.geojson"
    if not path.is_file():
        raise BuildingError(f"no bundled plan {name!r}; bundled plans: "
                            f"{', '.join(bundled_plans())}")
    return path
