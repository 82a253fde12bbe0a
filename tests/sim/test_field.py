"""The field scenario family: bundled and listed, deterministic per seed, and each field
condition there as stated (the world the simulator walks differs from the plan the
pipeline gets; furniture; deviating searches; drawn radio; failing breadcrumbs; teams)."""
from __future__ import annotations

import numpy as np
import pytest
import shapely
from shapely.geometry import LineString, Point

from firenav_framework.building import bundled_plan, load_building
from firenav_framework.cli import main
from firenav_framework.simulator import bundled_scenarios, load_scenario, simulate
from firenav_framework.simulator.radio import RADIO_RANGES
from firenav_framework.simulator.scenario import load_scenario_text
from firenav_framework.yaml_locations import ConfigError

FIELD = [n for n in bundled_scenarios() if n.startswith("field_")]
#: a cap per run for the determinism check: the world, the plan and the people are drawn
#: whole all the same, the signals only up to it
CAP_S = 30.0


def _crossings(floor, xy: np.ndarray) -> int:
    return int(floor.crosses_wall(xy[:-1], xy[1:]).sum())


def test_the_field_family_is_bundled_and_listed(capsys):
    assert len(FIELD) >= 8
    assert main(["simulate", "--list"]) == 0
    out = capsys.readouterr().out
    field = out[out.index("field:"):out.index("twin:")]
    assert all(name in field for name in FIELD)
    plans, grades = set(), set()
    for name in FIELD:
        sc = load_scenario(name)
        assert sc.model.family == "field"
        plans.add(sc.model.building)
        starts = {a.id: a.start.time_s for a in sc.model.agents}
        for agent in sc.model.agents:
            imu = agent.sensors.imu
            assert imu.errors == "as_worn"
            grades.add(imu.grade)
            begins = (starts[agent.id] if agent.follow is None
                      else starts[agent.follow.agent] + agent.follow.lag_s)
            assert begins - imu.switch_on_s <= 1.0 + 1e-9, (name, agent.id)   # no still start
    assert {"office_900", "three_storey", "apartments_4"} <= plans    # large, multi-floor
    assert "consumer" in grades and {"xsens_mti3", "xsens_mtw"} & grades


@pytest.mark.parametrize("name", bundled_scenarios())
def test_every_bundled_scenario_is_deterministic_per_seed(name):
    a, b = simulate(name, 1000, duration_s=CAP_S), simulate(name, 1000, duration_s=CAP_S)
    c = simulate(name, 1001, duration_s=CAP_S)
    for agent in a.imu:
        assert np.array_equal(a.imu[agent].gyro, b.imu[agent].gyro)
        assert np.array_equal(a.truth[agent].position, b.truth[agent].position)
        assert not np.array_equal(a.imu[agent].gyro, c.imu[agent].gyro)
    for port in a.messages:
        assert [m.digest() for m in a.messages[port]] == [m.digest() for m in b.messages[port]]
    assert a.breadcrumbs.keys() == b.breadcrumbs.keys() and a.radio == b.radio
    obstacles = [[o.polygon.wkt for o in f.obstacles] for f in a.world.floors]
    assert obstacles == [[o.polygon.wkt for o in f.obstacles] for f in b.world.floors]
    world = load_scenario(name).model.world
    if world is not None and world.furniture is not None:   # the furniture is drawn per seed
        assert obstacles != [[o.polygon.wkt for o in f.obstacles] for f in c.world.floors]


@pytest.fixture(scope="module")
def wrong_plan():
    return simulate("field_flat_wrong_plan", 1000)


def test_the_pipeline_gets_the_plan_and_the_truth_comes_from_the_world(wrong_plan):
    from firenav_framework.sources.simulator import SimulatorSource
    from firenav_framework.testing import make_component
    r = wrong_plan
    plan = load_building(bundled_plan("flat_125"))
    given, world = r.building.floor(0), r.world.floor(0)
    # the plan is the bundled file (plus the scenario's anchors), without furniture
    assert np.array_equal(given.walls, plan.floor(0).walls) and not given.obstacles
    assert {d.id for d in given.doors} == {d.id for d in plan.floor(0).doors}
    assert len(world.obstacles) >= 4
    # the world: bedroom 2's door moved 1.5 m, an opening between the bedrooms, the
    # office split by a partition with its own door
    moved = next(d for d in world.doors if d.id == "d_bed2")
    assert np.linalg.norm(moved.center - plan.door("d_bed2").center) == pytest.approx(1.5)
    assert any(np.allclose(o.center, [8.5, 2.0]) for o in world.openings)
    assert {"office", "office_b"} <= {room.id for room in world.rooms}
    assert _crossings(world, r.truth["ff1"].position[:, :2]) == 0
    # where the world differs, people walk through what the plan shows as walls
    text = """
building: flat_125
world:
  changes:
    - move_door: {door: d_bed2, by_m: -1.5}
    - remove_wall: {at: [8.5, 2.0], length_m: 0.9}
agents:
  - id: a
    start: {entrance: front, time_s: 1}
    plan: [{search: {hand: right}}]
"""
    other = simulate(load_scenario_text(text), 1000)
    body = other.truth["a"].position[:, :2]
    assert _crossings(other.world.floor(0), body) == 0
    assert _crossings(other.building.floor(0), body) >= 2
    # the simulator source hands a pipeline the plan, never the world
    src, _, _ = make_component(SimulatorSource, {"scenario": "field_flat_wrong_plan",
                                                 "seed": 1000, "duration": 20.0})
    assert not src.building().floor(0).obstacles
    assert np.array_equal(src.building().floor(0).walls, given.walls)


def test_searchers_go_round_the_furniture_they_follow(wrong_plan):
    r = wrong_plan
    world = r.world.floor(0)
    body = r.truth["ff1"].position[:, :2]
    pieces = shapely.union_all([o.polygon for o in world.obstacles])
    assert not LineString(body).intersects(pieces)
    # along a wall with furniture the hand-on-wall search follows the furniture's edge
    near = [o for o in world.obstacles if LineString(body).distance(o.polygon) < 0.7]
    assert len(near) >= 2
    for o in world.obstacles:   # never in a doorway
        assert all(o.polygon.distance(Point(*d.center)) > 0.9 for d in world.doors)


SMALL = """
building: flat_125
world:
  changes: [{change}]
agents:
  - id: a
    start: {{entrance: front, time_s: 1}}
    plan: [{{search: {{hand: right}}}}]
"""


@pytest.mark.parametrize("change, check", [
    ("{brick_up: d_bed1}", lambda w, p: "d_bed1" not in {d.id for d in w.doors}
     and len(w.walls) == len(p.walls) + 1),
    ("{add_wall: {from: [2.0, 10.0], to: [2.0, 7.0]}}",
     lambda w, p: w.crosses_wall(np.array([[1.0, 8.5]]), np.array([[3.0, 8.5]]))[0]
     and not p.crosses_wall(np.array([[1.0, 8.5]]), np.array([[3.0, 8.5]]))[0]),
    ("{remove_wall: {at: [5.0, 5.6], length_m: 1.2}}",
     lambda w, p: not w.crosses_wall(np.array([[5.0, 5.0]]), np.array([[5.0, 6.2]]))[0]
     and p.crosses_wall(np.array([[5.0, 5.0]]), np.array([[5.0, 6.2]]))[0]),
    ("{move_door: {door: d_kitchen, by_m: 1.0}}",
     lambda w, p: np.allclose(next(d for d in w.doors if d.id == "d_kitchen").center,
                              [3.2, 4.2])),
    ("{split_room: {room: kitchen, across: x, at: 0.7}}",
     lambda w, p: {"kitchen", "kitchen_b"} <= {r.id for r in w.rooms}
     and "kitchen_partition_door" in {d.id for d in w.doors}),
])
def test_each_kind_of_plan_error_is_made_as_stated(change, check):
    r = simulate(load_scenario_text(SMALL.format(change=change)), 1)
    assert check(r.world.floor(0), r.building.floor(0))
    assert _crossings(r.world.floor(0), r.truth["a"].position[:, :2]) == 0


def test_a_change_that_cannot_be_made_says_where():
    bad = SMALL.format(change="{brick_up: d_nowhere}")
    with pytest.raises(ConfigError, match=r"<string>:4:.*no door or opening 'd_nowhere'"):
        simulate(load_scenario_text(bad), 1)
    through = SMALL.format(change="{split_room: {room: living, across: x, at: 0.5}}")
    with pytest.raises(ConfigError, match="partition would run through d_living"):
        simulate(load_scenario_text(through), 1)


DEVIATE = """
building: area_250
agents:
  - id: a
    start: {{entrance: west, time_s: 1}}
    plan:
      - search: {{hand: left, gait: search, deviate: {dev}}}
"""


def _search(dev: str, seed: int = 3):
    return simulate(load_scenario_text(DEVIATE.format(dev=dev)), seed).truth["a"]


def test_deviating_searches_do_what_they_say():
    plain = _search("{}")
    short = _search("{coverage: 0.5}")
    assert short.distance_m == pytest.approx(0.5 * plain.distance_m, rel=0.1)
    # skipped rooms are never entered; the others are
    b = load_building(bundled_plan("area_250")).floor(0)

    def visited(tr):
        return {b.rooms[i].id for i in set(b.room_of(tr.position[:, :2])) if i >= 0}
    skipped = _search("{skip_rooms: 0.5}")
    assert len(visited(skipped)) < len(visited(plain)) - 2
    # running the corridor stretches (the rooms skipped make them long) at about 3 m/s;
    # crawling a share of the path
    mixed = _search("{skip_rooms: 0.7, run_in_corridors: true, crawl_share: 0.2}").strides
    length = np.linalg.norm(mixed.p1[:, :2] - mixed.p0[:, :2], axis=1)
    motion = np.array(list(mixed.motion))
    run = (motion[:-1] == "run") & (length[:-1] > 1.5)
    assert run.sum() >= 5
    assert 2.4 < np.median(length[:-1][run] / np.diff(mixed.t0)[run]) < 3.6
    crawled = length[motion == "crawl"].sum() / length.sum()
    assert 0.08 < crawled < 0.4
    # backtracking reverses the walking direction now and then
    back = _search("{backtrack_every_m: 15, backtrack_m: [2, 3]}")
    assert back.distance_m > plain.distance_m + 0.1 * plain.distance_m / 15 * 4
    # sweeping: the body stands while the foot slides out and back
    swept = _search("{sweep_every_m: 10}")
    sweep = np.array([m == "sweep" for m in swept.strides.motion])
    side = np.linalg.norm(swept.strides.p1[sweep, :2] - swept.strides.p0[sweep, :2], axis=1)
    assert sweep.sum() >= 8 and np.allclose(side, 0.35, atol=0.01)
    # leaving the wall shortens the loop
    assert _search("{leave_wall: 0.5}").distance_m < 0.95 * plain.distance_m


def test_radio_path_loss_is_drawn_per_building_and_seed_and_the_rssi_follows_it():
    draws = [simulate("field_breadcrumb_loop", s, duration_s=40).radio for s in range(6)]
    for key, (lo, hi) in RADIO_RANGES.items():
        values = [d[key] for d in draws]
        if key != "rssi_1m_dbm":
            assert all(lo <= v <= hi for v in values)
        assert np.std(values) > 0.1 * (hi - lo)
    other = simulate("field_breadcrumb_fire", 0, duration_s=40).radio
    assert other["exponent"] != draws[0]["exponent"]
    # the simulated RSSI of the base station heard by the user follows the drawn exponent
    r = simulate("field_breadcrumb_loop", 2, duration_s=120)
    tr = r.truth["ff1"]
    base = r.anchors["base"]["position"]
    heard = [m for m in r.messages["rssi"] if m.tx == "base" and m.rx == "ff1"]
    t = np.array([m.t for m in heard])
    p = np.column_stack([np.interp(t, tr.t, tr.position[:, i]) for i in range(2)])
    d = np.linalg.norm(p - base[:2], axis=1)
    near = d > 1.5
    slope = np.polyfit(10 * np.log10(d[near]), [m.rssi_dbm for m, k in zip(heard, near) if k], 1)[0]
    assert -slope == pytest.approx(r.radio["exponent"], abs=0.6)


def test_breadcrumbs_are_kicked_burned_and_lost_and_the_radio_knows():
    text = """
building: area_250
radio: {base_station: base}
fires: [{floor: 0, position: [6.0, 5.5], radius_m: 3.0, start_s: 0}]
agents:
  - id: ff1
    start: {entrance: west, time_s: 1}
    sensors:
      imu: {grade: consumer}
      dispenser: {capacity: 6, drop_below_dbm: -60, min_spacing_m: 2,
                  faults: {dud: 0.3, kick: 0.8, lost_per_min: 0.5}}
    plan:
      - walk: {to: [20.0, 5.5]}
      - walk: {to: [2.0, 5.5]}
      - walk: {to: [20.0, 5.5]}
      - wait: 120
      - walk: {to: [2.0, 5.5]}
  - id: ff2
    follow: {agent: ff1, lag_s: 3}
    sensors: {imu: {grade: consumer}, radio: true}
"""
    fates: dict[str, int] = {}
    for seed in (1, 2):
        r = simulate(load_scenario_text(text), seed)
        assert len(r.breadcrumbs) >= 4
        for node, info in r.breadcrumbs.items():
            fates[info["fate"]] = fates.get(info["fate"], 0) + 1
            fates["kicked"] = fates.get("kicked", 0) + bool(info["kicks"])
            sent = [m.t for m in r.messages["rssi"] if m.tx == node]
            heard = [m.t for m in r.messages["rssi"] if m.rx == node]
            if info["t_off"] is not None:         # silent from its end on, a dud throughout
                assert max(sent + heard, default=0) < info["t_off"] + 1e-3, node
            if info["fate"] == "dud":
                assert not sent and not heard, node
            moves = [info["position"][:2]] + [k[1:3] for k in info["kicks"]]
            for a, b in zip(moves, moves[1:]):
                assert 0.0 <= np.linalg.norm(np.subtract(b, a)) <= 3.0 + 1e-6
            if info["fate"] == "burned":
                assert np.linalg.norm(np.subtract(moves[-1], [6.0, 5.5])) <= 3.0
    assert fates.get("dud", 0) >= 1 and fates["kicked"] >= 2
    assert fates.get("lost", 0) + fates.get("burned", 0) >= 1


def test_uwb_anchor_out_of_line_of_sight_reads_long():
    r = simulate("field_corridor_run", 1000)
    info = r.extra["uwb"]
    assert info and np.mean([i["obstructions"] >= 1 for i in info]) > 0.9
    err = np.array([m.range_m - i["true_range_m"] for m, i in zip(r.messages["uwb"], info)])
    assert np.median(err) > 0.2


def test_several_teams_and_large_and_multi_floor_buildings():
    sc = load_scenario("field_office_large")
    teams = {}
    for a in sc.model.agents:
        teams.setdefault(a.team, []).append(a.id)
    assert len(teams) >= 2 and all(len(v) == 2 for v in teams.values())
    office = load_building(bundled_plan("office_900")).floor(0)
    assert office.outline.area >= 800 and len(office.rooms) >= 15
    r = simulate("field_apartments", 1000)
    assert len(r.world.floors) == 4
    assert set(np.unique(r.truth["ff1"].floor)) == {0, 1, 2}


def test_a_real_aamks_export_can_be_the_plan_of_a_field_world(shared_data, tmp_path):
    text = f"""
building: {shared_data / "aamks" / "simple.static.json"}
world:
  furniture: {{per_room: [2, 3], corridor: [1, 2]}}
agents:
  - id: a
    start: {{time_s: 1}}
    sensors: {{imu: {{grade: consumer}}}}
    plan: [{{search: {{hand: right, gait: search}}}}]
"""
    r = simulate(load_scenario_text(text, base_dir=tmp_path), 1000)
    world = r.world.floor(0)
    assert world.obstacles and not r.building.floor(0).obstacles
    assert r.truth["a"].distance_m > 30
    assert _crossings(world, r.truth["a"].position[:, :2]) == 0


@pytest.mark.parametrize("name", ["office_900", "apartments_4"])
def test_the_field_plans_are_what_plans_py_draws_and_pass_the_map_check(name):
    import json

    from firenav_framework.building.check import check_building
    from firenav_framework.building.plans import PLANS
    assert json.loads(bundled_plan(name).read_text()) == json.loads(json.dumps(
        PLANS[name]().geojson()))
    b = load_building(bundled_plan(name))
    assert check_building(b) == [] and b.entrances and b.georef is not None


def test_furniture_never_takes_an_id_the_plan_already_has():
    """The corridor plan has furniture of its own in room S4 (s4_desk1, ...); drawn
    furniture must not collide with it, whatever it draws."""
    from firenav_framework.simulator.world import build_world
    plan = load_building(bundled_plan("corridor"))
    spec = load_scenario("field_corridor_run").model.world
    for seed in range(12):
        world = build_world(plan, spec, np.random.default_rng(seed))
        ids = [o.id for o in world.floor(0).obstacles]
        assert len(ids) == len(set(ids)) and {o.id for o in plan.floor(0).obstacles} <= set(ids)
