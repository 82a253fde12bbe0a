"""The RFID tag database: candidate sites and the distance-cost association."""
from __future__ import annotations

import numpy as np
import pytest

from firenav_framework.building import bundled_plan, load_building
from firenav_framework.building.tags import (DOOR_TAG_HEIGHT, STAIR_TAG_HEIGHT, TagDatabase,
                                             candidate_tag_sites)

from .test_model import two_rooms


@pytest.fixture(scope="module")
def building():
    return two_rooms(levels=2).build()


def test_candidate_sites(building):
    sites = {s.id: s for s in candidate_tag_sites(building)}
    # Doors dAB0, dAB1, front; stair s0 bottom (floor 0) and top (floor 1).
    assert sorted(sites) == ["dAB0", "dAB1", "front", "s0/bottom", "s0/top"]
    assert sites["dAB1"].position.tolist() == [4.0, 1.5, 3.0 + DOOR_TAG_HEIGHT]
    assert sites["dAB1"].floor == 1 and sites["dAB1"].kind == "door"
    assert sites["dAB0"].axis.tolist() == pytest.approx([1, 0])
    bottom, top = sites["s0/bottom"], sites["s0/top"]
    assert (bottom.floor, top.floor) == (0, 1)
    assert bottom.position.tolist() == [5, 0.6, STAIR_TAG_HEIGHT]
    assert top.position.tolist() == [7.5, 0.6, 3.0 + STAIR_TAG_HEIGHT]
    assert bottom.heading == pytest.approx(0.0) and bottom.kind == "stair"


def test_openings_get_no_site():
    b = load_building(bundled_plan("area_250"))
    ids = {s.id for s in candidate_tag_sites(b)}
    assert "o_n5" not in ids and "d_n1_n2" in ids and len(ids) == len(b.doors)


def test_association_picks_nearest_free_site_on_the_floor(building):
    db = TagDatabase(building)
    # Dead reckoning puts the agent 0.8 m from dAB0 and 1.1 m from the stair bottom.
    assert db.associate("t1", [4.5, 2.1], floor=0).id == "dAB0"
    # The same position again for a new tag: dAB0 is taken, so the next cheapest site.
    assert db.associate("t2", [4.5, 2.1], floor=0).id == "s0/bottom"
    # Repeating a deployment keeps the first association.
    assert db.associate("t1", [0.0, 0.0], floor=0).id == "dAB0"
    # A 3-D position picks the floor from its height: z = 3.2 m is floor 1.
    assert db.associate("t3", [4.4, 1.0, 3.2]).id == "dAB1"
    assert db.lookup("t3").floor == 1 and db.lookup("nope") is None
    assert len(db) == 3


def test_anisotropic_uncertainty_changes_the_choice(building):
    # From (2.5, 1.5): front door 2.5 m west, dAB0 1.5 m east -> dAB0 by plain distance.
    db = TagDatabase(building)
    assert db.costs([2.5, 1.5], floor=0)[[s.id for s in db.sites].index("dAB0")] == pytest.approx(2.25)
    assert db.associate("a", [2.5, 1.5], floor=0).id == "dAB0"
    # From (4.9, 2.4): dAB0 (4, 1.5) is 1.27 m away, the stair bottom (5, 0.6) 1.80 m, so an
    # isotropic sigma picks dAB0. A track sure in x (sigma 0.1 m) but not in y (3 m): dAB0
    # costs 0.9^2/0.01 + 0.9^2/9 = 81.09, the stair 0.1^2/0.01 + 1.8^2/9 = 1.36.
    assert TagDatabase(building).associate("b", [4.9, 2.4], floor=0, sigma=0.5).id == "dAB0"
    db = TagDatabase(building)
    cov = np.diag([0.1**2, 3.0**2])
    cost = dict(zip([s.id for s in db.sites], db.costs([4.9, 2.4], 0, cov)))
    assert cost["dAB0"] == pytest.approx(81.09) and cost["s0/bottom"] == pytest.approx(1.36)
    assert db.associate("c", [4.9, 2.4], floor=0, sigma=cov).id == "s0/bottom"


def test_gate_and_exhaustion(building):
    db = TagDatabase(building)
    assert db.associate("far", [40.0, 40.0], floor=0, sigma=1.0, gate=3.0) is None
    assert db.lookup("far") is None
    for k in range(len(db.sites)):
        db.associate(f"t{k}", [4.0, 1.5], floor=0)
    with pytest.raises(LookupError, match="all tagged"):
        db.associate("one_too_many", [4.0, 1.5], floor=0)


def test_assign_and_bad_input(building):
    db = TagDatabase(building)
    assert db.assign("surveyed", "s0/top").floor == 1
    with pytest.raises(KeyError, match="no tag site 'x'"):
        db.assign("t", "x")
    with pytest.raises(ValueError, match="finite"):
        db.associate("t", [np.nan, 0.0])
    with pytest.raises(ValueError, match="positive"):
        db.associate("t", [0.0, 0.0], sigma=-1.0)
    with pytest.raises(ValueError, match="covariance"):
        db.associate("t", [0.0, 0.0], sigma=np.array([[1.0, 2.0], [2.0, 1.0]]))


def test_three_storey_database():
    b = load_building(bundled_plan("three_storey"))
    sites = candidate_tag_sites(b)
    assert len(sites) == len(b.doors) + 2 * len(b.stairs)
    db = TagDatabase(b)
    # A tag placed at the top of the first flight, seen from a drifted track on floor 1.
    site = db.associate("stair_top", [4.4, 8.5, 3.6])
    assert site.id == "stair01/top" and site.axis.tolist() == pytest.approx([0, -1])
