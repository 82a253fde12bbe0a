"""rssi_breadcrumb: path-loss ranges, encounter peaks (§V-A), kicked breadcrumbs, bad input."""
from __future__ import annotations

import math

import numpy as np
import pytest

from firenav_framework import BreadcrumbDrop, RssiReading
from firenav_framework.testing import check_plugin, make_component, run_component
from firenav_plugins.sensors.rssi_breadcrumb import (RssiBreadcrumbSensor, range_sigma,
                                                     rssi_to_range)

P = {"rssi_1m_dbm": -40.0, "path_loss_exponent": 2.5, "shadowing_db": 4.0}


def reading(t, tx, rx, rssi, agent="ff1"):
    return ("rssi", RssiReading(t=t, agent=agent, device=f"{agent}/radio", tx=tx, rx=rx,
                                rssi_dbm=rssi))


def drop(t, node, agent="ff1"):
    return ("drops", BreadcrumbDrop(t=t, agent=agent, device=f"{agent}/dispenser",
                                    node_id=node))


def test_path_loss_inversion_and_range_dependent_sigma():
    assert rssi_to_range(-40.0, -40.0, 2.5) == pytest.approx(1.0)
    assert rssi_to_range(-65.0, -40.0, 2.5) == pytest.approx(10.0)
    # delta method: sigma_d = d sigma_dB ln10 / (10 n), proportional to the range
    assert range_sigma(10.0, 4.0, 2.5) == pytest.approx(10 * 4 * math.log(10) / 25)
    rec = run_component(RssiBreadcrumbSensor, P, [drop(0.0, "bc1"), reading(1.0, "bc1", "ff1", -65.0)])
    (r,) = rec.on("range")
    assert (r.a, r.b, r.method, r.agent) == ("bc1", "ff1", "rssi", "ff1")
    assert r.range_m == pytest.approx(10.0)
    assert r.sigma_m == pytest.approx(range_sigma(10.0, 4.0, 2.5))


def test_impossible_readings_are_counted_and_skipped():
    comp, rec, stats = make_component(RssiBreadcrumbSensor, P)
    comp.handle(*drop(0.0, "bc1"))
    for msg in [reading(1.0, "bc1", "ff1", 5.0),            # above 0 dBm
                reading(1.1, "bc1", "ff1", float("nan")),
                reading(1.2, "bc1", "ff1", -150.0),         # below any sensitivity
                reading(1.3, "ff1", "ff1", -50.0),          # hears itself
                reading(1.4, "bc9", "ff1", -50.0),          # never dropped, unknown
                reading(1.5, "ghost", "ff1", -50.0)]:
        comp.handle(*msg)
    comp.handle(*drop(3.0, "bc2"))
    comp.handle(*reading(2.5, "bc2", "ff1", -50.0))         # before bc2 was dropped
    comp.handle(*reading(4.0, "bc2", "ff1", -50.0))         # fine
    counts = stats.counts["under_test"]
    assert counts["rejected_rssi_too_high"] == 1 and counts["rejected_non_finite"] == 1
    assert counts["rejected_rssi_too_low"] == 1 and counts["rejected_self_reading"] == 1
    assert counts["rejected_unknown_node"] == 2 and counts["rejected_not_dropped_yet"] == 1
    assert len(rec.on("range")) == 1
    warn = [d for d in rec.on("diagnostics") if d.code == "unknown_radio_node"]
    assert len(warn) == 2                                  # once per unknown id


def test_one_encounter_per_pass_at_the_rssi_peak():
    """§V-A: RSSI above -40 dBm when passing within a metre; the local maximum marks it."""
    t = np.arange(0.0, 60.0, 1.0)
    rng = np.random.default_rng(0)
    # passes at t = 12 and t = 41 (closest 0.3 m), otherwise walking 1.2 m/s past
    d = np.minimum(np.hypot(1.2 * (t - 12), 0.3), np.hypot(1.2 * (t - 41), 0.3))
    rssi = -40.0 - 25.0 * np.log10(d) + rng.normal(0, 1.0, len(t))
    msgs = [drop(0.0, "bc1")] + [reading(ti, "bc1", "ff1", round(r)) for ti, r in zip(t, rssi)]
    rec = run_component(RssiBreadcrumbSensor, P, msgs)
    enc = rec.on("encounters")
    assert [e.t for e in enc] == pytest.approx([12.0, 41.0], abs=1.0)
    for e in enc:
        assert (e.a, e.b, e.method, e.agent) == ("ff1", "bc1", "rssi_encounter", "ff1")
        assert e.range_m < 1.5 and e.sigma_m == 1.0
    # a pass at 3 m never reaches -40 dBm: no encounter
    far = [drop(0.0, "bc1")] + [reading(ti, "bc1", "ff1", -40 - 25 * math.log10(
        math.hypot(1.2 * (ti - 12), 3.0))) for ti in t]
    assert run_component(RssiBreadcrumbSensor, P, far).on("encounters") == []


def fixed_links(t_kick: float | None, moved: str = "bc2", shift: float = 10.0):
    """Readings among base, bc1..bc3 (fixed) for 200 s; ``moved``'s links shift at t_kick."""
    rng = np.random.default_rng(3)
    nodes = ["base", "bc1", "bc2", "bc3"]
    level = {pair: -60.0 - 5.0 * k for k, pair in enumerate(
        [(a, b) for i, a in enumerate(nodes) for b in nodes[i + 1:]])}
    msgs = [drop(0.0, "bc1"), drop(0.0, "bc2"), drop(0.0, "bc3")]
    for ti in np.arange(1.0, 200.0, 1.0):
        for (a, b), lv in level.items():
            shifted = t_kick is not None and ti >= t_kick and moved in (a, b)
            msgs.append(reading(ti, a, b, round(lv - (shift if shifted else 0.0)
                                                + rng.normal(0, 2.5)), agent=""))
    return msgs


def test_kicked_breadcrumb_is_detected_from_its_fixed_links():
    """§V-B/C: a moved breadcrumb changes the RSSI of its links to the other fixed nodes."""
    rec = run_component(RssiBreadcrumbSensor, P, fixed_links(100.0))
    moved = rec.on("moved")
    assert [m.node_id for m in moved] == ["bc2"]
    assert 95.0 <= moved[0].t <= 110.0 and moved[0].agent == ""
    assert any(d.code == "breadcrumb_moved" for d in rec.on("diagnostics"))
    # steady links: nothing moves
    assert run_component(RssiBreadcrumbSensor, P, fixed_links(None)).on("moved") == []


def test_conforms_to_the_plugin_contract():
    # two readings of one link, so the contract's out-of-time-order case applies too
    check_plugin(RssiBreadcrumbSensor, P, sample_input=[drop(0.0, "bc1"),
                                                        reading(1.0, "bc1", "ff1", -45.0),
                                                        reading(2.0, "bc1", "ff1", -38.0),
                                                        reading(3.0, "bc1", "ff1", -50.0)])


def test_a_reading_older_than_its_links_last_is_counted_dropped_and_warned_once():
    """Issue 13's finding: a late reading moved the encounter peak and nothing said so.
    An older reading of the same link (either direction) is dropped and counted; other
    links' readings at that time are unaffected."""
    clean = [drop(0.0, "bc1"), drop(0.0, "bc2")] + [
        reading(float(t), "bc1", "ff1", r) for t, r in
        [(1, -50.0), (2, -44.0), (3, -38.0), (4, -42.0), (5, -55.0)]]
    late = [*clean[:5], reading(2.5, "ff1", "bc1", -30.0),     # older than t=3: dropped
            reading(2.5, "bc2", "ff1", -60.0),                  # another link: kept
            *clean[5:], reading(4.5, "bc1", "ff1", -36.0)]      # older than t=5: dropped
    want = run_component(RssiBreadcrumbSensor, P, clean)
    comp, rec, stats = make_component(RssiBreadcrumbSensor, P)
    comp.start()
    for s, m in late:
        comp.handle(s, m)
    comp.finish()
    assert stats.counts["under_test"]["out_of_order"] == 2
    enc, = rec.on("encounters")
    assert enc.t == 3.0 and enc.range_m == pytest.approx(want.on("encounters")[0].range_m)
    assert [r.t for r in rec.on("range")] == [1.0, 2.0, 3.0, 2.5, 4.0, 5.0]
    warn = [d for d in rec.on("diagnostics") if d.code == "rssi_out_of_order"]
    assert len(warn) == 1 and "bc1-ff1" in warn[0].text and warn[0].level == "warning"


def test_silent_breadcrumbs_are_reported_once_duds_and_dead_apart():
    """A dud never heard after its drop and a breadcrumb that falls silent (burned, lost)
    are each said once after ``silent_s``; one that keeps talking never."""
    msgs = [drop(0.0, "bc1"), drop(0.0, "bc2"), drop(0.0, "bc3")]
    for t in range(1, 200):
        msgs.append(reading(float(t), "bc1", "base", -60.0))
        if t < 30:
            msgs.append(reading(float(t) + 0.5, "bc3", "base", -62.0))
    comp, rec, stats = make_component(RssiBreadcrumbSensor, {**P, "silent_s": 60.0})
    comp.start()
    for s, m in msgs:
        comp.handle(s, m)
    said = {d.text.split(":")[0]: d for d in rec.on("diagnostics") if d.code == "breadcrumb_silent"}
    assert set(said) == {"breadcrumb bc2", "breadcrumb bc3"}
    assert "dud" in said["breadcrumb bc2"].text and 60.0 <= said["breadcrumb bc2"].t <= 70.0
    assert "silent since t = 30 s" in said["breadcrumb bc3"].text     # last heard 29.5 s
    assert 89.0 <= said["breadcrumb bc3"].t <= 100.0
    assert stats.counts["under_test"]["breadcrumbs_silent"] == 2
