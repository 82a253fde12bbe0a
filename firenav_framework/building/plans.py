"""The bundled buildings, drawn to scale after the reference papers' test sites.

Each function returns the :class:`PlanSketch` of one plan; ``data/<name>.geojson`` is its
written form (regenerate with ``python -m firenav_framework.building.plans``; a test
checks the files match). Walls are zero-thickness centre lines, doors 0.9-1.2 m gaps.

* ``flat_125``: a 12.5 x 10 m (125 m^2) flat / small office, a hall and six furniture-free
  rooms with one door each: the navigation area of data set 1 of the search-pattern
  paper (search-pattern-particle-filter, Sec. V-A: "a larger area of size 125 m^2").
* ``area_250``: a 23 x 11 m (253 m^2) floor with a central corridor and twelve rooms,
  including a room behind a room and a doorless kitchenette: data set 2 (Sec. V-A).
* ``office_loop``: a 50 x 22 m office floor whose ring corridor's centre line is a
  40 x 10 m rectangle, 100 m per lap, with offices on both sides and a core inside the
  ring; the base station sits at the upper-right corner of the loop where the walk
  starts (breadcrumb-gen-rmg, Sec. V-A: 400 m = 4 laps of 100 m, anticlockwise).
* ``corridor``: a 40 m corridor 3 m wide (walls at y = 6.9 and 9.9 m, centre line
  y = 8.4 m where the ORCA paper's check points lie, Table 1) with side rooms and doors,
  one of them furnished (Test III); a UWB anchor at the start point (5.12, 8.40)
  (orca-map-matching, Sec. 3.2).
* ``three_storey``: a 30 x 14 m building of three storeys (3.5 m floor to floor) with a
  U-shaped stairwell in the west end, the main entrance to the south and offices on a
  central corridor (rfid-mems-ekf "Testing scenario"; zupt-extension stair-house trials).
* ``office_900``: a 45 x 20 m (900 m^2) office floor: a 2.4 m corridor end to end with
  exits at both ends, eight rooms to the south (one a 10 m meeting room with two doors)
  and nine to the north (two connected, a kitchen open to the corridor), most of them
  alike: 18 rooms, a floor as large as the field scenarios need.
* ``apartments_4``: a four-storey block of flats, 20 x 12 m (2.9 m floor to floor): a
  stair core in the middle with the entrance to the south and a U stair, a flat of five
  rooms on either side of it on every storey.
"""
from __future__ import annotations

import sys
from pathlib import Path

from .bundled import DATA_DIR
from .sketch import INTERIOR_DOOR, PlanSketch

__all__ = ["PLANS", "write_all"]

DOOR = INTERIOR_DOOR
EXIT = 1.2      # exterior door width [m]
NORTH, EAST = (0.0, 1.0), (1.0, 0.0)


def flat_125() -> PlanSketch:
    sk = PlanSketch("flat_125")
    f = sk.floor(0.0, 2.6, "flat")
    f.room("hall", (0.0, 4.2, 12.5, 5.6), "hall", use="corridor")
    f.room("kitchen", (0.0, 0.0, 4.5, 4.2), "kitchen")
    f.room("bedroom1", (4.5, 0.0, 8.5, 4.2), "bedroom 1")
    f.room("bedroom2", (8.5, 0.0, 12.5, 4.2), "bedroom 2")
    f.room("living", (0.0, 5.6, 6.0, 10.0), "living room")
    f.room("bath", (6.0, 5.6, 8.5, 10.0), "bathroom")
    f.room("office", (8.5, 5.6, 12.5, 10.0), "office")
    f.door("d_kitchen", (2.2, 4.2), DOOR, NORTH)
    f.door("d_bed1", (6.5, 4.2), DOOR, NORTH)
    f.door("d_bed2", (10.5, 4.2), DOOR, NORTH)
    f.door("d_living", (3.0, 5.6), DOOR, NORTH)
    f.door("d_bath", (7.2, 5.6), 0.8, NORTH)
    f.door("d_office", (10.5, 5.6), DOOR, NORTH)
    f.door("d_front", (0.0, 4.9), 1.0, EAST)
    sk.entrance("front", (0.0, 4.9), door="d_front")
    sk.base_station((-4.0, 4.9))
    sk.georef(59.3498, 18.0707)          # KTH campus, Stockholm
    return sk


def area_250() -> PlanSketch:
    sk = PlanSketch("area_250")
    f = sk.floor(0.0, 3.0, "ground")
    f.room("corridor", (0.0, 4.5, 23.0, 6.5), "corridor", use="corridor")
    f.room_row("s", [0.0, 4.0, 7.5, 11.0, 15.0, 19.0, 23.0], 0.0, 4.5, "room S", door_at=-0.8)
    f.room_row("n", [0.0, 5.0, 8.0, 11.0, 15.0, 19.0, 23.0], 6.5, 11.0, "room N")
    f.door("d_n1", (4.2, 6.5), DOOR, NORTH)
    f.door("d_n1_n2", (5.0, 9.5), DOOR, EAST)          # N2 is only reached through N1
    f.door("d_n3", (9.0, 6.5), DOOR, NORTH)
    f.door("d_n4", (12.0, 6.5), DOOR, NORTH)
    f.opening("o_n5", (17.0, 6.5), 2.0, NORTH)          # kitchenette, open to the corridor
    f.door("d_n6", (20.0, 6.5), DOOR, NORTH)
    f.door("d_west", (0.0, 5.5), EXIT, EAST)
    f.door("d_east", (23.0, 5.5), EXIT, (-1.0, 0.0))
    sk.entrance("west", (0.0, 5.5), door="d_west")
    sk.entrance("east", (23.0, 5.5), door="d_east")
    sk.base_station((-3.0, 5.5))
    sk.georef(59.4045, 17.9494, bearing_deg=15.0)     # Kista, Stockholm; plan turned 15 deg
    return sk


def office_loop() -> PlanSketch:
    sk = PlanSketch("office_loop")
    f = sk.floor(0.0, 3.5, "4th floor")
    # Ring corridor 2 m wide around the core: centre line x 5..45, y 6..16 (100 m).
    f.room("corridor", [(4.0, 5.0), (46.0, 5.0), (46.0, 17.0), (4.0, 17.0)], "ring corridor",
           use="corridor", holes=[[(6.0, 7.0), (44.0, 7.0), (44.0, 15.0), (6.0, 15.0)]])
    for k in range(12):
        x0 = 4.0 + 3.5 * k
        f.room(f"s{k + 1}", (x0, 0.0, x0 + 3.5, 5.0), f"office S{k + 1}")
        f.door(f"d_s{k + 1}", (x0 + 2.6, 5.0), DOOR, NORTH)
        f.room(f"n{k + 1}", (x0, 17.0, x0 + 3.5, 22.0), f"office N{k + 1}")
        f.door(f"d_n{k + 1}", (x0 + 2.6, 17.0), DOOR, NORTH)
    core = [6.0, 12.0, 18.0, 24.0, 30.0, 36.0, 44.0]
    for k, (x0, x1) in enumerate(zip(core, core[1:]), 1):
        f.room(f"cs{k}", (x0, 7.0, x1, 11.0), f"core S{k}")
        f.door(f"d_cs{k}", (x0 + 1.5, 7.0), DOOR, NORTH)
        f.room(f"cn{k}", (x0, 11.0, x1, 15.0), f"core N{k}")
        f.door(f"d_cn{k}", (x1 - 1.5, 15.0), DOOR, NORTH)
    for side, x0, x1, xd in (("w", 0.0, 4.0, 4.0), ("e", 46.0, 50.0, 46.0)):
        f.room(f"{side}1", (x0, 0.0, x1, 7.0), f"end room {side.upper()}1")
        f.door(f"d_{side}1", (xd, 6.0), DOOR, EAST)
        f.room(f"{side}2", (x0, 7.0, x1, 15.0), "stair lobby" if side == "e" else "server room",
               use="stairwell" if side == "e" else "room")
        f.door(f"d_{side}2", (xd, 11.0), 1.0, EAST)
        f.room(f"{side}3", (x0, 15.0, x1, 22.0), f"end room {side.upper()}3")
        f.door(f"d_{side}3", (xd, 16.0), DOOR, EAST)
    sk.entrance("lobby", (46.0, 11.0), heading_deg=180.0, door="d_e2")
    sk.base_station((45.0, 16.0))
    sk.georef(31.2990, 120.5853)          # Suzhou
    return sk


def corridor() -> PlanSketch:
    sk = PlanSketch("corridor")
    f = sk.floor(0.0, 3.0, "ground")
    f.room("corridor", (0.0, 6.9, 40.0, 9.9), "corridor", use="corridor")
    f.room_row("s", [0.0, 6.0, 12.0, 18.0, 26.0, 32.0, 40.0], 0.0, 6.9, "room S", door_at=1.2)
    f.room_row("n", [0.0, 5.0, 10.0, 15.0, 21.0, 27.0, 33.0, 40.0], 9.9, 15.9, "room N",
               door_at=-1.0, door_y=9.9)
    # S4 is the furnished compartment of Test III: desks, a table and cupboards.
    f.obstacle("s4_table", (20.5, 2.5, 23.5, 4.0))
    f.obstacle("s4_desk1", (18.0, 0.0, 19.6, 0.8))
    f.obstacle("s4_desk2", (24.4, 0.0, 26.0, 0.8))
    f.obstacle("s4_cupboard", (25.4, 2.0, 26.0, 5.0))
    f.door("d_west", (0.0, 8.4), EXIT, EAST)
    f.door("d_east", (40.0, 8.4), EXIT, (-1.0, 0.0))
    sk.entrance("west", (0.0, 8.4), door="d_west")
    sk.anchor("uwb_start", (5.12, 8.40), height=1.0, kind="uwb")
    sk.base_station((-3.0, 8.4))
    sk.georef(51.7469, 19.4533)          # Lodz
    return sk


def three_storey() -> PlanSketch:
    sk = PlanSketch("three_storey")
    # U stair in the stairwell x 0..5.5, y 5.5..14: flight 1 north at x = 1.4, landing at
    # y = 12.6, flight 2 south at x = 4.1; each storey's landing is y 5.5..8.
    stair_path = [(1.4, 8.0), (1.4, 12.6), (4.1, 12.6), (4.1, 8.0)]
    for level, f in enumerate(sk.storeys(3.5, ["ground", "first", "second"])):
        f.room("stairwell" if level == 0 else f"stairwell{level}", (0.0, 5.5, 5.5, 14.0),
               "stairwell", use="stairwell")
        f.door(f"d{level}_stair", (5.5, 6.75), 1.0, EAST)
        f.room(f"corridor{level}", (5.5, 5.5, 30.0, 8.0), "corridor", use="corridor")
        south = [0.0, 5.5, 11.0, 16.0, 21.0, 25.5, 30.0]
        for k, (x0, x1) in enumerate(zip(south, south[1:]), 1):
            lobby = level == 0 and k == 3
            f.room(f"{level}s{k}", (x0, 0.0, x1, 5.5), "entrance lobby" if lobby else
                   f"office {level}.S{k}", use="hall" if lobby else "room")
            if k == 1:   # below the stairwell: reached from the stair landing
                f.door(f"d{level}_s1", (3.0, 5.5), DOOR, NORTH)
            elif lobby:
                f.opening(f"o{level}_lobby", (13.5, 5.5), 2.4, NORTH)
            else:
                f.door(f"d{level}_s{k}", (x1 - 1.0, 5.5), DOOR, NORTH)
        north = [5.5, 10.5, 15.5, 20.5, 25.5, 30.0]
        for k, (x0, x1) in enumerate(zip(north, north[1:]), 1):
            fire = level == 2 and k == 3
            f.room(f"{level}n{k}", (x0, 8.0, x1, 14.0), "fire room" if fire else
                   f"office {level}.N{k}")
            f.door(f"d{level}_n{k}", (x0 + 1.0, 8.0), DOOR, NORTH)
        if level < 2:
            f.stair(f"stair{level}{level + 1}", stair_path, floor_to=level + 1, width=1.2,
                    n_steps=20)
    sk.floors[0].door("d_main", (13.5, 0.0), 1.6, NORTH)
    sk.entrance("main", (13.5, 0.0), door="d_main")
    sk.base_station((13.5, -5.0))
    sk.georef(46.5191, 6.5668, bearing_deg=20.0)     # EPFL, Lausanne; plan turned 20 deg
    return sk


def office_900() -> PlanSketch:
    sk = PlanSketch("office_900")
    f = sk.floor(0.0, 3.2, "ground")
    f.room("corridor", (0.0, 8.8, 45.0, 11.2), "corridor", use="corridor")
    south = [0.0, 5.0, 10.0, 15.0, 25.0, 30.0, 35.0, 40.0, 45.0]
    for k, (x0, x1) in enumerate(zip(south, south[1:]), 1):
        meeting = x1 - x0 > 6.0
        f.room(f"s{k}", (x0, 0.0, x1, 8.8), "meeting room" if meeting else f"office S{k}")
        if meeting:
            f.door(f"d_s{k}a", (x0 + 1.5, 8.8), DOOR, NORTH)
            f.door(f"d_s{k}b", (x1 - 1.5, 8.8), DOOR, NORTH)
        else:
            f.door(f"d_s{k}", (x1 - 1.0, 8.8), DOOR, NORTH)
    for k in range(9):
        x0 = 5.0 * k
        kitchen = k == 8
        f.room(f"n{k + 1}", (x0, 11.2, x0 + 5.0, 20.0), "kitchen" if kitchen else
               f"office N{k + 1}")
        if kitchen:
            f.opening(f"o_n{k + 1}", (x0 + 2.5, 11.2), 2.0, NORTH)
        else:
            f.door(f"d_n{k + 1}", (x0 + 1.0, 11.2), DOOR, NORTH)
    f.door("d_n4_n5", (20.0, 17.0), DOOR, EAST)       # N5 also opens into N4
    f.door("d_west", (0.0, 10.0), EXIT, EAST)
    f.door("d_east", (45.0, 10.0), EXIT, (-1.0, 0.0))
    sk.entrance("west", (0.0, 10.0), door="d_west")
    sk.entrance("east", (45.0, 10.0), door="d_east")
    sk.base_station((-3.0, 10.0))
    sk.georef(52.2297, 21.0122)          # Warsaw
    return sk


def apartments_4() -> PlanSketch:
    sk = PlanSketch("apartments_4")
    # U stair in the core x 8..12, y 6..12: flight 1 north at x = 9, landing at y = 11.2,
    # flight 2 south at x = 11; each storey's part of the core south of it is its lobby.
    stair_path = [(9.0, 8.4), (9.0, 11.2), (11.0, 11.2), (11.0, 8.4)]
    for level, f in enumerate(sk.storeys(2.9, ["ground", "first", "second", "third"])):
        f.room(f"{level}core", (8.0, 0.0, 12.0, 12.0), "stair core", use="stairwell")
        for side, x0, x1, door_x, sign in (("w", 0.0, 8.0, 8.0, -1.0), ("e", 12.0, 20.0, 12.0,
                                                                          1.0)):
            inner, outer = (5.0, 8.0) if side == "w" else (12.0, 15.0)
            room_x = (x0, 5.0) if side == "w" else (15.0, x1)
            f.room(f"{level}{side}h", (inner, 3.0, outer, 9.0), "flat hallway", use="corridor")
            f.room(f"{level}{side}l", (room_x[0], 6.0, room_x[1], 12.0), "living room")
            f.room(f"{level}{side}b", (room_x[0], 0.0, room_x[1], 6.0), "bedroom")
            f.room(f"{level}{side}k", (inner, 9.0, outer, 12.0), "kitchen")
            f.room(f"{level}{side}ba", (inner, 0.0, outer, 3.0), "bathroom")
            inner_wall = 5.0 if side == "w" else 15.0
            mid = (inner + outer) / 2
            f.door(f"d{level}{side}_flat", (door_x, 4.5), DOOR, (sign, 0.0))
            f.door(f"d{level}{side}_l", (inner_wall, 7.5), DOOR, (-sign, 0.0))
            f.door(f"d{level}{side}_b", (inner_wall, 4.5), DOOR, (-sign, 0.0))
            f.door(f"d{level}{side}_k", (mid, 9.0), DOOR, NORTH)
            f.door(f"d{level}{side}_ba", (mid, 3.0), 0.8, NORTH)
        if level < 3:
            f.stair(f"stair{level}{level + 1}", stair_path, floor_to=level + 1, width=1.0,
                    n_steps=17)
    sk.floors[0].door("d_main", (10.0, 0.0), 1.2, NORTH)
    sk.entrance("main", (10.0, 0.0), door="d_main")
    sk.base_station((10.0, -4.0))
    sk.georef(51.7592, 19.4560)          # Lodz
    return sk


PLANS = {"flat_125": flat_125, "area_250": area_250, "office_loop": office_loop,
         "corridor": corridor, "three_storey": three_storey, "office_900": office_900,
         "apartments_4": apartments_4}


def write_all(directory: Path = DATA_DIR) -> list[Path]:
    """(Re)write every bundled plan as ``<directory>/<name>.geojson``."""
    out = []
    for name, make in PLANS.items():
        path = directory / f"{name}.geojson"
        make().write(path)
        out.append(path)
    return out


if __name__ == "__main__":
    for p in write_all(Path(sys.argv[1]) if len(sys.argv) > 1 else DATA_DIR):
        print(p)
