"""Size limits of a plan, so that one bad value cannot make loading hang or run out of memory.

Every importer (native GeoJSON, Aamks, DXF) ends in the same model, and the work of
building it (wall index, outline, ``map check``) grows with the number of floors,
segments, features and wall contacts. A plan beyond one of these limits is refused
with a :class:`~.model.BuildingError` that names the file, the feature and the limit,
before that work starts. The limits are far above any real building (the tallest has
163 storeys; a large hospital floor has a few thousand wall segments) and are listed
in docs/building-format.md.

Coordinates are checked after unit conversion: plan metres from the building origin.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .model import BuildingError

__all__ = ["MAX_PLAN_BYTES", "MAX_FLOORS", "MAX_FEATURES", "MAX_VERTICES", "MAX_COORD_M",
           "MAX_LEVEL_M", "MAX_WALL_SEGMENTS_PER_FLOOR", "MAX_WALL_SEGMENTS",
           "MAX_WALL_CONTACTS_PER_FLOOR", "MAX_ITEMS_PER_FLOOR", "MAX_ARC_SEGMENTS",
           "check_file_size", "check_floor_count", "check_coordinates", "check_level",
           "check_count"]

#: Largest plan file read [bytes] (64 MiB).
MAX_PLAN_BYTES = 64 * 2 ** 20
#: Most floors in one building.
MAX_FLOORS = 200
#: Most features (walls, doors, rooms, ...) in one plan.
MAX_FEATURES = 200_000
#: Most vertices in one geometry (a wall polyline, a room outline).
MAX_VERTICES = 100_000
#: Largest horizontal distance [m] of any point from the plan origin (100 km).
MAX_COORD_M = 1.0e5
#: Largest floor level [m] above or below the origin (10 km).
MAX_LEVEL_M = 1.0e4
#: Most wall segments on one floor (obstacle edges included) and in the building.
MAX_WALL_SEGMENTS_PER_FLOOR = 50_000
MAX_WALL_SEGMENTS = 500_000
#: Most touching or crossing pairs of wall segments on one floor. Real walls meet at
#: their ends (a few contacts per segment); random lines cross everywhere and make the
#: outline (the faces of every crossing) quadratic in time and memory.
MAX_WALL_CONTACTS_PER_FLOOR = 200_000
#: Most rooms, doors, openings, obstacles and stairs on one floor, together.
MAX_ITEMS_PER_FLOOR = 20_000
#: Most straight pieces one DXF arc or polyline bulge is flattened into.
MAX_ARC_SEGMENTS = 1024


def check_file_size(path: Path) -> None:
    """Refuse a plan file larger than :data:`MAX_PLAN_BYTES` (or one that is no file)."""
    try:
        size = path.stat().st_size
    except OSError as exc:
        raise BuildingError(f"{path}: cannot read the plan ({exc.strerror})") from None
    if not path.is_file():
        raise BuildingError(f"{path}: not a regular file")
    if size > MAX_PLAN_BYTES:
        raise BuildingError(f"{path}: the plan file is {size / 2 ** 20:.0f} MiB; plans are "
                            f"limited to {MAX_PLAN_BYTES // 2 ** 20} MiB")


def check_floor_count(where: str, n: int) -> None:
    if n > MAX_FLOORS:
        raise BuildingError(f"{where}: {n} floors; a building may have at most {MAX_FLOORS}")


def check_count(where: str, what: str, n: int, limit: int) -> None:
    """Refuse ``n`` items of ``what`` beyond ``limit``."""
    if n > limit:
        raise BuildingError(f"{where}: {n} {what}; the limit is {limit}")


def check_coordinates(where: str, xy: np.ndarray) -> None:
    """Refuse non-finite points or points farther than :data:`MAX_COORD_M` from the origin.

    ``xy`` (..., 2) plan metres.
    """
    pts = np.asarray(xy, dtype=float).reshape(-1, 2)
    if len(pts) > MAX_VERTICES:
        raise BuildingError(f"{where}: {len(pts)} vertices in one geometry; the limit is "
                            f"{MAX_VERTICES}")
    if not np.all(np.isfinite(pts)):
        raise BuildingError(f"{where}: geometry has NaN or infinite coordinates")
    if len(pts) and np.abs(pts).max() > MAX_COORD_M:
        k = int(np.abs(pts).max(axis=1).argmax())
        raise BuildingError(f"{where}: point ({pts[k, 0]:.6g}, {pts[k, 1]:.6g}) m is farther "
                            f"than {MAX_COORD_M:.0f} m from the plan origin (wrong unit, or "
                            "a damaged value?)")


def check_level(where: str, name: str, value: float) -> None:
    """Refuse a floor level or height [m] beyond :data:`MAX_LEVEL_M`."""
    if abs(value) > MAX_LEVEL_M:
        raise BuildingError(f"{where}: {name} {value:.6g} m is beyond +-{MAX_LEVEL_M:.0f} m")
