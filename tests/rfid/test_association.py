"""Tag deployment: association with the most probable door by the distance cost."""
from __future__ import annotations

import math

import numpy as np
import pytest

from firenav_framework import TagDeployment, TagDetection
from firenav_framework.building import bundled_plan, load_building
from firenav_framework.testing import make_component
from firenav_plugins.estimators.pdr_ekf import PdrEkfEstimator

from .synth import closest_passes, deployments, feed, odometry, walk

DEG = math.pi / 180


@pytest.fixture(scope="module")
def building():
    return load_building(bundled_plan("three_storey"))


def deploy(building, w, doors, *, scale=1.0, rate=0.0, **params):
    """Walk ``w`` with MEMS errors, deploying a tag at each door of ``doors`` passed."""
    sites = {d: building.door(d).center for d in doors}
    tags = {d: f"T_{d}" for d in doors}
    odo = odometry(w, scale=scale, rate=rate)
    ekf, rec, stats = make_component(PdrEkfEstimator, params, building=building)
    ekf.start()
    feed(ekf, odo + deployments(closest_passes(w, sites), tags))
    return ekf, rec, tags


@pytest.mark.parametrize("scale", [0.94, 1.0, 1.06])
def test_the_door_passed_wins_over_its_close_neighbours(building, scale):
    """Along the corridor to d0_n1 (6.5, 8), with the step length 6 % off either way:
    d0_stair is 1.6 m away, d0_s1 and d0_n2 about 4 m; the tag goes to d0_n1 (when the
    track's uncertainty leaves d0_stair a fair chance, tentatively, d0_n1 named first)."""
    w = walk([(13.5, 0.0), (13.5, 6.75), (6.5, 6.75), (6.5, 10.0)], stride=1.2)
    ekf, rec, tags = deploy(building, w, ["d0_n1"], scale=scale)
    assert ekf.tags.lookup(tags["d0_n1"]).id == "d0_n1"
    assoc = [d for d in rec.on("diagnostics") if d.code in ("tag_associated", "tag_ambiguous")]
    assert len(assoc) == 1
    assert ("-> d0_n1 (floor 0)" in assoc[0].text if assoc[0].code == "tag_associated"
            else "floor 0: d0_n1 " in assoc[0].text)


def test_two_neighbouring_doors_tagged_in_a_row(building):
    """In through d0_n1, out again and on through d0_stair 1.6 m away, the step length
    8 % long: each tag goes to its own door (the first one's site is taken, and the
    deployment correction keeps the estimate on track for the second)."""
    w = walk([(13.5, 0.0), (13.5, 6.75), (6.5, 6.75), (6.5, 9.5), (6.5, 6.75), (4.5, 6.75)],
             stride=1.2)
    ekf, _, tags = deploy(building, w, ["d0_n1", "d0_stair"], scale=1.08)
    assert ekf.tags.lookup(tags["d0_n1"]).id == "d0_n1"
    assert ekf.tags.lookup(tags["d0_stair"]).id == "d0_stair"


def test_a_second_tag_on_a_tagged_door_takes_the_next_free_site(building):
    """The database holds one tag per site: a second tag stuck at the same door goes to
    the most probable free site, and the first keeps its door."""
    w = walk([(13.5, 0.0), (13.5, 6.75), (6.5, 6.75), (6.5, 9.5)], stride=1.2)
    t = closest_passes(w, {"d": (6.5, 8.0)})[0][0]
    deps = [TagDeployment(t=t, agent="ff1", device="ff1/rfid", tag_id="A"),
            TagDeployment(t=t + 0.5, agent="ff1", device="ff1/rfid", tag_id="B")]
    ekf, _, _ = make_component(PdrEkfEstimator, {}, building=building)
    ekf.start()
    feed(ekf, odometry(w) + deps)
    assert ekf.tags.lookup("A").id == "d0_n1"
    assert ekf.tags.lookup("B").id == "d0_stair"      # the nearest other door


def test_the_floor_comes_from_the_height(building):
    """stair12/bottom (floor 1) sits exactly above stair01/bottom (floor 0): an agent on
    floor 1 (Z = 3.5 m) associates its tag with the floor-1 site."""
    w = walk([(4.0, 7.0), (1.6, 7.4), (1.4, 9.0)], stride=0.9)
    odo = odometry(w)
    t = closest_passes(w, {"s": (1.4, 8.0)})[0][0]
    ekf, _, _ = make_component(PdrEkfEstimator, {"start": {"mode": "pose", "position": (4.0, 7.0, 3.5),
                                                      "heading": math.atan2(0.4, -2.4)}},
                               building=building)
    ekf.start()
    feed(ekf, odo + [TagDeployment(t=t, agent="ff1", device="ff1/rfid", tag_id="S")])
    assert ekf.tags.lookup("S").id == "stair12/bottom"


def test_the_deploying_agent_is_corrected_and_later_agents_use_the_tag(building):
    """ff1's step length is 15 % long, so its estimate is over a metre off at the door;
    the deployment pulls it towards the door (weighted by the tag and track
    uncertainties: the tag's pinned at 0.5 m here, a read right at the door; the default
    also covers plans whose doors are a metre off). ff2 (another agent of the same
    estimator, i.e. the same database) reads the tag later and is corrected by it."""
    w = walk([(13.5, 0.0), (13.5, 6.75), (16.5, 6.75), (16.5, 10.0)], stride=1.2)
    ekf, rec, tags = deploy(building, w, ["d0_n3"], scale=1.15, rfid={"sigma": 0.5})
    poses = [p for p in rec.on("pose") if p.agent == "ff1"]
    t_dep = closest_passes(w, {"d": (16.5, 8.0)})[0][0]
    before = [p for p in poses if p.t <= t_dep][-1]
    after = [p for p in poses if p.t > t_dep + 1.0][0]
    err_before = np.hypot(*(before.position[:2] - w.at(before.t)[:2]))
    err_after = np.hypot(*(after.position[:2] - w.at(after.t)[:2]))
    assert err_before > 0.8 and err_after < 0.6 * err_before

    w2 = walk([(13.5, 0.0), (13.5, 6.75), (16.5, 6.75), (16.5, 10.0)], stride=1.2, t0=200.0)
    odo2 = odometry(w2, agent="ff2", scale=1.15)
    t2 = closest_passes(w2, {"d": (16.5, 8.0)})[0][0]
    read = TagDetection(t=t2, agent="ff2", device="ff2/rfid", tag_id=tags["d0_n3"], reads=4)
    feed(ekf, odo2 + [read])
    last = [p for p in rec.on("pose") if p.agent == "ff2"][-1]
    assert np.hypot(*(last.position[:2] - w2.p[-1, :2])) < 0.6 * err_before


def test_a_deployment_far_from_every_site_is_reported_with_a_gate(building):
    """With associate_gate, a tag stuck in the middle of a room (no door within the
    gate) is not associated: reported, and its later reads are unknown."""
    w = walk([(13.5, 0.0), (13.5, 3.0)], stride=1.0)
    dep = TagDeployment(t=float(w.t[-1]), agent="ff1", device="ff1/rfid", tag_id="LOST")
    read = TagDetection(t=float(w.t[-1]) + 5.0, agent="ff1", device="ff1/rfid",
                        tag_id="LOST", reads=2)
    ekf, rec, stats = make_component(PdrEkfEstimator, {"rfid": {"associate_gate": 2.0, "repeat_holdoff": 0.0}},
                                     building=building)
    ekf.start()
    feed(ekf, odometry(w) + [dep, read])
    assert ekf.tags.lookup("LOST") is None
    counts = stats.counts["under_test"]
    assert counts["tags_not_associated"] == 1 and counts["tags_unknown"] == 1
    (d,) = [d for d in rec.on("diagnostics") if d.code == "tag_not_associated"]
    assert "no tag site close enough" in d.text
