"""Radio, UWB and RFID models: signal falls with distance and walls, ranges are
biased through walls, tags are read only near them, dispensers drop when the link weakens."""
from __future__ import annotations

import numpy as np
import pytest

from firenav_framework.building import bundled_plan, load_building
from firenav_framework.simulator import simulate
from firenav_framework.simulator.radio import LinkModel, Node
from firenav_framework.simulator.rfid import rfid_detections
from firenav_framework.simulator.scenario import Fire, Radio, RfidConfig, UwbConfig
from firenav_framework.simulator.uwb import uwb_ranges


@pytest.fixture(scope="module")
def corridor():
    return load_building(bundled_plan("corridor"))


def _mean_rssi(model: LinkModel, a: np.ndarray, b: np.ndarray, n: int = 400) -> float:
    """Average over many packets and over a small area (shadowing is spatial)."""
    rng = np.random.default_rng(0)
    t = np.arange(n, dtype=float)
    jitter = rng.uniform(-1.0, 1.0, (n, 2))
    pa = np.repeat(np.asarray(a, float)[None], n, 0)
    pa[:, 0] += jitter[:, 0]
    tx = Node("tx", position=None, track=lambda tt: (pa, np.zeros(n, int), np.full(n, np.nan)))
    rx = Node("rx", position=np.asarray(b, float), floor=0)
    rssi, ok = model.sample(t, tx, rx, rng)
    return float(rssi[ok].mean()) if ok.any() else -np.inf


def test_rssi_falls_with_distance_like_the_log_distance_model(corridor):
    cfg = Radio(shadowing_db=0.0, body_db=0.0)
    model = LinkModel(cfg, corridor, [], np.random.default_rng(1))
    rx = [2.0, 8.4, 1.0]
    d = np.array([2.0, 4.0, 8.0, 16.0, 32.0])
    means = np.array([_mean_rssi(model, [2.0 + di, 8.4, 1.0], rx) for di in d])
    assert np.all(np.diff(means) < 0)
    slope = np.polyfit(np.log10(d), means, 1)[0]      # dB per decade
    assert slope == pytest.approx(-10 * cfg.exponent, abs=2.5)
    assert means[0] == pytest.approx(cfg.rssi_1m_dbm - 10 * cfg.exponent * np.log10(2), abs=1.5)


def test_walls_and_floors_attenuate(corridor):
    cfg = Radio(shadowing_db=0.0, body_db=0.0)
    model = LinkModel(cfg, corridor, [], np.random.default_rng(2))
    # 6 m apart: along the corridor (no wall) vs. from the corridor into room N3 and N5
    los = _mean_rssi(model, [14.0, 8.4, 1.0], [20.0, 8.4, 1.0])
    walls = model.walls_between(np.array([[12.5, 12.5]]), np.array([0]), np.array([[18.5, 12.5]]))
    assert walls[0] == 1          # the wall between rooms N3 and N4
    through = _mean_rssi(model, [12.5, 12.5, 1.0], [18.5, 12.5, 1.0])
    assert los - through == pytest.approx(cfg.wall_db, abs=1.0)
    three = load_building(bundled_plan("three_storey"))
    m3 = LinkModel(cfg, three, [], np.random.default_rng(3))
    a = np.array([[20.0, 3.0, 1.2]])
    up = m3.mean_rssi(np.zeros(1), a, np.array([0]), a + [0, 0, 3.5], np.array([1]))[0]
    same = m3.mean_rssi(np.zeros(1), a, np.array([0]), a + [3.5, 0, 0], np.array([0]))[0]
    assert same - up == pytest.approx(cfg.floor_db + 0.0, abs=cfg.wall_db + 0.01)


def test_fire_between_nodes_lowers_the_rssi(corridor):
    cfg = Radio(shadowing_db=0.0, body_db=0.0)
    fire = Fire(floor=0, position=(20.0, 8.4), radius_m=1.5, loss_db_per_m=4.0, fading_db=5.0)
    cold = LinkModel(cfg, corridor, [], np.random.default_rng(4))
    hot = LinkModel(cfg, corridor, [fire], np.random.default_rng(4))
    a, b = [17.0, 8.4, 1.0], [23.0, 8.4, 1.0]
    loss = _mean_rssi(cold, a, b) - _mean_rssi(hot, a, b)
    assert loss == pytest.approx(4.0 * 3.0, abs=2.0)   # 3 m of the line inside the fire


def test_shadowing_is_smooth_in_space_and_fixed_for_fixed_nodes(corridor):
    model = LinkModel(Radio(fading_db=0.0, body_db=0.0), corridor, [], np.random.default_rng(5))
    a = Node("bc1", position=np.array([5.0, 8.4, 0.05]))
    b = Node("bc2", position=np.array([15.0, 8.4, 0.05]))
    r1, _ = model.sample(np.arange(50.0), a, b, np.random.default_rng(6))
    assert np.ptp(r1) <= 1.0          # static pair: only the integer rounding
    field = model.shadow("bc1")
    x = np.column_stack([np.linspace(0, 10, 1001), np.full(1001, 8.4)])
    s = field(x)
    assert s.std() > 1.0 and np.abs(np.diff(s)).max() < 0.5   # metres of decorrelation


def test_uwb_is_unbiased_in_line_of_sight_and_late_through_walls():
    cfg = UwbConfig(outlier_prob=0.0, dropout_prob=0.0, dropout_per_wall=0.0)
    n = 4000
    rng = np.random.default_rng(7)
    tag = np.column_stack([rng.uniform(5, 15, n), np.full(n, 8.4), np.full(n, 1.4)])
    anchor = np.array([2.0, 8.4, 1.0])
    results = {}
    for walls in (0, 2):
        keep, meas, truth = uwb_ranges(np.arange(n) * 0.5, tag, np.zeros(n, int), anchor, 0, cfg,
                                       np.full(n, walls), 3.0, np.random.default_rng(8))
        err = meas[keep] - truth["true_range_m"][keep]
        results[walls] = err
    assert abs(results[0].mean()) < 0.01 and results[0].std() == pytest.approx(0.10, rel=0.1)
    assert results[2].mean() == pytest.approx(2 * cfg.nlos_bias_m, rel=0.3)
    assert np.mean(results[2] > 0) > 0.75 and np.median(results[2]) > 0.4
    drop_cfg = UwbConfig(dropout_prob=0.02, dropout_per_wall=0.1)
    kept = [uwb_ranges(np.arange(n) * 0.5, tag, np.zeros(n, int), anchor, 0, drop_cfg,
                       np.full(n, w), 3.0, np.random.default_rng(9))[0].mean() for w in (0, 3)]
    assert kept[0] == pytest.approx(0.98, abs=0.01) and kept[1] == pytest.approx(0.68, abs=0.03)


def test_rfid_reads_only_near_a_tag_after_it_was_stuck():
    cfg = RfidConfig(range_m=1.0, rate_hz=10, window_s=1.0)
    t = np.arange(0.0, 40.0, 0.1)
    x = np.interp(t, [0, 40], [-10.0, 10.0])          # walk past the tag at x = 0 at t = 20
    reader = np.column_stack([x, np.zeros_like(t), np.full_like(t, 1.2)])
    tag = ("E2TEST", np.array([0.0, 0.3, 2.0]), 5.0)
    det = rfid_detections(t, reader, [tag], cfg, np.random.default_rng(1))
    assert det, "passing under a tag reads it"
    times = np.array([d[0] for d in det])
    assert np.all(np.abs(np.interp(times, t, x)) < 1.6)
    late = rfid_detections(t, reader, [("E2LATE", tag[1], 30.0)], cfg, np.random.default_rng(1))
    assert late == []                                  # stuck after the reader went by
    assert sum(d[2] for d in det) >= 5                 # several reads aggregated


def test_dispenser_drops_breadcrumbs_when_the_link_weakens():
    text = """
building: office_loop
agents:
  - id: ff1
    start: {position: [45.0, 16.0], floor: 0, heading_deg: 180, time_s: 3}
    sensors:
      imu: null
      dispenser: {capacity: 3, drop_below_dbm: -74}
    plan:
      - walk: {via: [[5.0, 16.0], [5.0, 6.0], [45.0, 6.0]]}
"""
    from firenav_framework.simulator.scenario import load_scenario_text
    r = simulate(load_scenario_text(text), 0)
    drops = list(r.breadcrumbs.values())
    assert 1 <= len(drops) <= 3
    base = r.anchors["base"]["position"]
    d = [np.linalg.norm(v["position"][:2] - base[:2]) for v in drops]
    assert d[0] > 8.0                              # not next to the base station
    assert all(np.diff([v["t"] for v in drops]) > 0)
    readings = r.messages["rssi"]
    # the chain is heard: every dropped node's packets reach the firefighter
    for node in r.breadcrumbs:
        assert any(m.tx == node and m.rx == "ff1" for m in readings)
    # packets between breadcrumbs belong to no firefighter
    assert all(m.agent == "" for m in readings if m.tx.startswith("bc") and m.rx.startswith("bc"))


def test_simulated_tags_name_the_sites_of_the_tag_database():
    """Every stuck tag's ``feature`` (doors and both stair ends) is a tag-database site id,
    and the tag lies at that site (within the jamb/stair-end height difference)."""
    from firenav_framework.building.tags import candidate_tag_sites
    from firenav_framework.simulator.scenario import load_scenario

    r = simulate(load_scenario("rfid_route"), 3)
    sites = {s.id: s for s in candidate_tag_sites(r.building)}
    features = [v["feature"] for v in r.tags.values()]
    assert any(f.endswith("/bottom") for f in features) and any(f.endswith("/top") for f in features)
    for v in r.tags.values():
        site = sites[v["feature"]]
        assert np.linalg.norm(np.asarray(v["position"])[:2] - site.position[:2]) < 0.5
