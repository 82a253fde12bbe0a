"""The building model: floors, walls, doors, rooms, stairs, anchors; formats and queries.

Frame: local level metres, x/y horizontal, z up, one origin for all floors (ENU when the
georef bearing is 0). Headings: radians CCW from +x. Formats: the native GeoJSON plan
(docs/building-format.md), Aamks JSON exports, DXF with a layer map.
"""
from .bundled import bundled_plan, bundled_plans
from .georef import GeoRef
from .loader import load_building
from .model import (Anchor, Building, BuildingError, Door, DoorCrossing, Entrance, Floor,
                    Obstacle, Room, Stair)

__all__ = ["Building", "Floor", "Door", "Room", "Stair", "Obstacle", "Anchor", "Entrance",
           "GeoRef", "DoorCrossing", "BuildingError", "load_building", "bundled_plan",
           "bundled_plans"]
