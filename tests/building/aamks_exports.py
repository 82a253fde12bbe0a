"""Small multi-floor Aamks exports written the way Aamks writes them (test content).

:func:`cad_export` gives a ``cad.json`` document: per floor key, lists of ROOM, COR, HALL,
STAI, DOOR, HOLE, WIN, OBST, VVENT, FIRE records with ``points`` and ``z`` as JSON
strings in centimetres and a building-wide ``idx``; stairwells and a two-storey hall are
drawn once, on the floor they start on, with a z range over the floors they serve.

:func:`static_export` derives the matching ``static.json`` by Aamks's rules: a tall STAI
or HALL gets a slice ``<name>.<floor>`` on every floor its z range reaches; walls are
4 cm rectangles along each compartment edge (so a shared wall comes twice) with the
door and hole rectangles cut out; HOLEs are left out of ``doors``; ``floor_meta`` has
``minz_abs``/``maxz_abs`` from everything but towers and ``zdim = maxz_abs`` minus the
floor below's ``maxz_abs`` (which a tall obstacle or a ceiling vent throws off).

The building (three storeys 3.5 m apart, x east, y north, cm): corridor ``c`` along
y 0-300, room ``r`` at x 0-800 north of it on every floor, a hall ``a`` x 800-1700 two
storeys high on floor 0 (a room upstairs on floor 2), stairwell ``A`` x 1700-2400,
y 300-750 serving all floors with its door at the west end of its south wall, and
stairwell ``B`` x -500-0, y -200-900 serving floors 0-1, entered from the corridor at
its south end on floor 0 and from room ``r`` at its north end on floor 1. The front
door is in the corridor's south wall at x 1000-1090.
"""
from __future__ import annotations

import json

from shapely.geometry import MultiPolygon, Polygon, box

LEVELS = (0, 350, 700)
WALL = 4         # Aamks walls_width [cm]
STOREY = 350


def _rect(x0, y0, x1, y1):
    return [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]


def _door_h(x0, y, width=90):
    """Door rectangle across a horizontal wall at y (32 cm deep, as Aamks draws them)."""
    return _rect(x0, y - 16, x0 + width, y + 16)


def _door_v(x, y0, width=90):
    return _rect(x - 16, y0, x + 16, y0 + width)


def cad_export() -> dict:
    """The building as a cad.json document (see the module docstring)."""
    idx = iter(range(1, 1000))
    floors: dict[str, dict[str, list]] = {}

    def add(key, kind, points, z, **extra):
        floors.setdefault(key, {}).setdefault(kind, []).append(
            {"points": json.dumps(points), "idx": next(idx), "z": json.dumps(list(z)), **extra})

    for i, z0 in enumerate(LEVELS):
        key = str(i)
        z1 = z0 + STOREY
        add(key, "COR", _rect(0, 0, 2400, 300), (z0, z1), room_enter="yes")
        add(key, "ROOM", _rect(0, 300, 800, 900), (z0, z1), room_enter="yes")
        add(key, "DOOR", _door_h(300, 300), (z0, z0 + 200))       # corridor - room r
        add(key, "DOOR", _door_h(1760, 300), (z0, z0 + 200))      # corridor - stairwell A
        for kind in ("HOLE", "WIN", "DCLOSER", "DELECTR", "MVENT", "EVACUEE"):
            floors[key].setdefault(kind, [])
    add("0", "HALL", _rect(800, 300, 1700, 900), (0, 700), room_enter="yes")
    add("0", "STAI", _rect(1700, 300, 2400, 750), (0, 1050), room_enter="yes")
    add("0", "STAI", _rect(-500, -200, 0, 900), (0, 700), room_enter="yes")
    add("0", "DOOR", _door_h(1200, 300), (0, 200))                # corridor - hall
    add("0", "DOOR", _door_h(1000, 0), (0, 200))                  # front door
    add("0", "DOOR", _door_v(0, 50), (0, 200))                    # corridor - stairwell B
    add("0", "WIN", _door_h(1900, 0, 200), (100, 250))
    add("0", "FIRE", _rect(400, 500, 500, 600), (0, 250))
    add("1", "DOOR", _door_v(0, 760), (350, 550))                 # room r - stairwell B
    add("1", "OBST", _rect(200, 500, 300, 600), (350, 1000))      # a column through floor 2
    add("2", "ROOM", _rect(800, 300, 1700, 900), (700, 1050), room_enter="yes")
    add("2", "DOOR", _door_h(1200, 300), (700, 900))              # corridor - room
    add("2", "HOLE", _door_h(500, 300, 200), (700, 1050))         # corridor - room r, open
    add("2", "VVENT", _rect(1000, 500, 1100, 600), (1046, 1054))  # roof vent
    add("0", "DOOR", _door_v(2400, 400), (0, 200))                # stairwell A - outside
    for key in floors:
        floors[key]["UNDERLAY_IMG"] = {"opacity": "1", "invert": "0", "scale": "none",
                                       "rotate": "none", "translate": "none"}
        floors[key]["UNDERLAY_FLOOR"] = {}
    return floors


_LETTER = {"ROOM": "r", "COR": "c", "HALL": "a", "STAI": "s", "DOOR": "d", "HOLE": "z",
           "DCLOSER": "q", "DELECTR": "e"}


def _records(cad: dict, key: str):
    for kind, items in cad[key].items():
        if isinstance(items, list):
            for item in items:
                yield kind, item, json.loads(item["points"]), json.loads(item["z"])


def static_export(cad: dict) -> dict:
    """The static.json Aamks derives from ``cad`` (see the module docstring)."""
    keys = sorted(cad, key=float)
    meta = {}
    prev_top = 0
    for key in keys:
        zs = [z for kind, _, _, z in _records(cad, key) if kind not in ("STAI", "HALL")]
        lo, hi = min(z[0] for z in zs), max(z[1] for z in zs)
        meta[key] = {"name": key, "minz_abs": lo, "maxz_abs": hi, "zdim": hi - prev_top}
        prev_top = hi
    rooms = {k: {} for k in keys}
    for key in keys:
        for kind, item, pts, z in _records(cad, key):
            if kind not in ("ROOM", "COR", "HALL", "STAI"):
                continue
            name = f"{_LETTER[kind]}{item['idx']}"
            rooms[key][name] = (kind, pts)
            if kind in ("STAI", "HALL") and z[1] >= meta[key]["maxz_abs"] + 200:
                for other in keys:
                    if other != key and z[0] <= meta[other]["minz_abs"] < z[1]:
                        rooms[other][f"{name}.{other}"] = (kind, pts)
    out = {"world_meta": {"walls_width": WALL}, "floors": {}}
    for key in keys:
        doors = {f"{_LETTER[kind]}{item['idx']}": (kind, pts)
                 for kind, item, pts, _ in _records(cad, key)
                 if kind in ("DOOR", "DCLOSER", "DELECTR", "HOLE")}
        cuts = [Polygon(pts) for _, pts in doors.values()]
        walls = set()
        for _, pts in rooms[key].values():
            x0, y0 = min(p[0] for p in pts), min(p[1] for p in pts)
            x1, y1 = max(p[0] for p in pts), max(p[1] for p in pts)
            walls |= {(x0 + WALL, y0, x1, y0 + WALL), (x1, y0, x1 + WALL, y1 + WALL),
                      (x0 + WALL, y1, x1, y1 + WALL), (x0, y0, x0 + WALL, y1 + WALL)}
        obstacles = [[p for p in pts] + [pts[0]] for kind, _, pts, _ in _records(cad, key)
                     if kind == "OBST"]
        for w in sorted(walls):
            piece = box(*w)
            for c in cuts:
                piece = piece.difference(c)
            for part in (piece.geoms if isinstance(piece, MultiPolygon) else [piece]):
                if not part.is_empty:
                    obstacles.append([[int(x), int(y)] for x, y in part.exterior.coords])
        out["floors"][key] = {
            "floor_meta": meta[key],
            "rooms": {n: {"name": n, "type_sec": kind, "room_enter": "yes",
                          "points": json.dumps(pts + [pts[0]])}
                      for n, (kind, pts) in rooms[key].items()},
            "doors": {n: {"name": n, "type_sec": kind, "points": json.dumps(pts + [pts[0]])}
                      for n, (kind, pts) in doors.items() if kind != "HOLE"},
            "obstacles": [json.dumps(o) for o in obstacles],
            "dd_geoms": {"rectangle": [], "path": [], "circle": [], "text": []},
            "evacuees": [],
        }
    return out


def write_exports(folder) -> tuple:
    """Write ``three.cad.json`` and ``three.static.json`` into ``folder``; their paths."""
    cad = cad_export()
    cad_path = folder / "three.cad.json"
    static_path = folder / "three.static.json"
    cad_path.write_text(json.dumps(cad, indent=1))
    static_path.write_text(json.dumps(static_export(cad), indent=1))
    return cad_path, static_path
