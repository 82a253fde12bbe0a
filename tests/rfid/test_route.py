"""The whole estimator on a synthetic route through doors of the three-storey plan.

Truth is known exactly: the first firefighter deploys a tag at every door it passes
(associated by the distance cost of the tag database), a second one walks the same
route later with only a reader. Both are compared with MEMS alone (rfid: false).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from firenav_framework import Odometry, TagDetection
from firenav_framework.building import bundled_plan, load_building
from firenav_framework.testing import check_plugin, make_component
from firenav_plugins.estimators.pdr_ekf import PdrEkfEstimator
from tests.contract.known import known

from .synth import (closest_passes, deployments, detections, feed, odometry, track_errors,
                    walk)

DEG = math.pi / 180
#: Entrance -> north rooms and south rooms of the ground floor, the stairwell door, back.
ROUTE = [(13.5, 0.0), (13.5, 6.75), (16.5, 6.75), (16.5, 11.0), (16.5, 6.75), (10.0, 6.75),
         (10.0, 3.0), (10.0, 6.75), (6.5, 6.75), (6.5, 11.0), (6.5, 6.75), (4.0, 6.75),
         (4.0, 6.0), (5.5, 6.75), (21.5, 6.75), (21.5, 11.0), (21.5, 6.75), (24.5, 6.75),
         (24.5, 3.0), (24.5, 6.75), (13.5, 6.75), (13.5, 0.5)]
DOORS = ["d0_n3", "d0_s2", "d0_n1", "d0_stair", "d0_n4", "d0_s5"]
TAGS = {d: f"E2{i:010X}" for i, d in enumerate(DOORS)}


@pytest.fixture(scope="module")
def building():
    return load_building(bundled_plan("three_storey"))


@pytest.fixture(scope="module")
def team(building):
    """ff1 deploys, ff2 (worse gyro) follows 60 s after ff1 came back out."""
    sites = {d: building.door(d).center for d in DOORS}
    w1 = walk(ROUTE, stride=1.3, t0=10.0)
    w2 = walk(ROUTE, stride=1.25, t0=float(w1.t[-1]) + 60.0)
    rng = np.random.default_rng(7)
    odo1 = odometry(w1, agent="ff1", yaw=-2.0, rate=0.3 * DEG, scale=1.03, noise=0.03, rng=rng)
    odo2 = odometry(w2, agent="ff2", yaw=1.1, rate=-0.4 * DEG, scale=0.96, noise=0.03, rng=rng)
    p1, p2 = closest_passes(w1, sites), closest_passes(w2, sites)
    msgs = (odo1 + odo2 + deployments(p1, TAGS, "ff1") + detections(p1, TAGS, "ff1")
            + detections(p2, TAGS, "ff2"))
    return w1, w2, odo1 + odo2, msgs


def run(building, msgs, **params):
    ekf, rec, stats = make_component(PdrEkfEstimator, params, building=building)
    ekf.start()
    feed(ekf, msgs)
    return ekf, rec, stats.counts.get("under_test", {})


def test_first_team_tags_are_associated_with_the_right_doors(building, team):
    """Every deployment, made from the dead-reckoned estimate, lands on the door it was
    stuck on, also where doors are 1.6 m apart (d0_n1, d0_stair)."""
    _, _, _, msgs = team
    ekf, rec, counts = run(building, msgs)
    assert counts["tags_associated"] == len(DOORS)
    for door, tag in TAGS.items():
        assert ekf.tags.lookup(tag).id == door
    assert not [d for d in rec.on("diagnostics") if d.level != "info"]


def test_rfid_beats_mems_alone_and_the_second_team_benefits(building, team):
    w1, w2, odo, msgs = team
    _, rec, counts = run(building, msgs)
    _, rec_mems, _ = run(building, odo, rfid={"enabled": False})
    for agent, truth in (("ff1", w1), ("ff2", w2)):
        hybrid = track_errors(rec.on("pose"), truth, agent)
        mems = track_errors(rec_mems.on("pose"), truth, agent)
        assert len(hybrid) == len(mems) > 50
        assert np.percentile(hybrid, 90) < 1.5, agent
        assert hybrid.mean() < 0.4 * mems.mean(), agent
    assert counts["tag_updates"] >= 2 * len(DOORS)
    assert counts["door_headings"] >= len(DOORS)


def test_poses_are_synchronous_with_covariance_and_floor(building, team):
    w1, _, _, msgs = team
    _, rec, _ = run(building, msgs)
    poses = [p for p in rec.on("pose") if p.agent == "ff1"]
    dt = np.diff([p.t for p in poses])
    assert np.all(dt > 0) and np.median(dt) == pytest.approx(1.3, abs=0.3)   # one per update
    assert all(p.floor == 0 for p in poses)
    for p in poses:
        assert np.all(np.linalg.eigvalsh(p.cov) > 0)
    # an update per stride (asynchronous) gives one pose per stride
    _, rec_async, _ = run(building, msgs, update_period=None)
    assert len([p for p in rec_async.on("pose") if p.agent == "ff1"]) == len(w1.t) - 1


def test_unknown_and_repeated_tags_are_counted_not_fatal(building, team):
    _, _, _, msgs = team
    extra = [TagDetection(t=60.0, agent="ff1", device="ff1/rfid", tag_id="STRANGER", reads=3),
             TagDetection(t=61.0, agent="ff1", device="ff1/rfid", tag_id="STRANGER", reads=2)]
    ekf, rec, counts = run(building, msgs + extra)
    assert counts["tags_unknown"] == 2
    warn = [d for d in rec.on("diagnostics") if d.code == "unknown_tag"]
    assert len(warn) == 1 and "STRANGER" in warn[0].text
    assert counts["tag_repeats_ignored"] >= len(DOORS)   # ff1 reads the tags it just stuck
    assert counts["tags_associated"] == len(DOORS)


def test_a_tag_far_from_the_estimate_relocates_or_is_refused(building):
    """A detection 15 m from a well-known position: by default the track is re-located
    at the tag (a read means the reader is within a metre or two); with on_gate=reject
    (duplicated ids possible) it is refused and reported."""
    w = walk([(13.5, 0.0), (13.5, 6.75), (20.0, 6.75)], stride=1.3)
    odo = odometry(w)
    far = TagDetection(t=float(w.t[-2]), agent="ff1", device="ff1/rfid", tag_id="T", reads=4)
    for mode, code in (("relocate", "tag_relocation"), ("reject", "tag_rejected")):
        _, rec, counts = run(building, odo + [far], rfid={"surveyed": {"T": "d0_n5"}, "on_gate": mode})
        assert [d.code for d in rec.on("diagnostics") if d.level == "warning"] == [code]
        end = rec.on("pose")[-1].position
        if mode == "relocate":
            assert np.hypot(*(end[:2] - building.door("d0_n5").center)) < 3.0
        else:
            assert np.hypot(*(end[:2] - w.p[-1, :2])) < 0.5


def test_a_relocation_returns_the_step_scale_to_the_ins(building):
    """Tag updates of a drifted track (wrong associations) can teach the step scale
    lambda a wrong value; the read that relocates the track says they were wrong, so
    lambda returns to its prior, the INS's own scale, and the next leg is walked at it.
    Here the odometry is exact and lambda has been taught 0.5 when a surveyed tag 5 m
    from the estimate is read: 22.5 m walked after it end within 2 m of the truth with
    the rule, about 11 m short with rfid.relocate_scale false."""
    w = walk([(13.5, 0.0), (13.5, 6.75), (5.5, 6.75), (28.0, 6.75)], stride=1.3)
    at_tag = int(np.flatnonzero(np.all(np.isclose(w.p[:, :2], (5.5, 6.75)), axis=1))[0])
    odo = odometry(w)
    read = TagDetection(t=float(w.t[at_tag]) + 0.01, agent="ff1", device="ff1/rfid",
                        tag_id="T", reads=4)
    ends = {}
    for rule in (True, False):
        ekf, rec, _ = make_component(PdrEkfEstimator, {
            "rfid": {"surveyed": {"T": "d0_stair"}, "gate": 3.0, "relocate_scale": rule}},
            building=building)
        ekf.start()
        feed(_Taught(ekf, scale=0.5), odo + [read])
        assert [d.code for d in rec.on("diagnostics") if d.level == "warning"] == ["tag_relocation"]
        ends[rule] = float(np.hypot(*(rec.on("pose")[-1].position[:2] - w.p[-1, :2])))
    assert ends[True] < 2.0
    assert ends[False] > 8.0


class _Taught:
    """A component whose agents' step scale is set to ``scale`` (with a small variance,
    uncorrelated: as if learned) right after their filter starts."""

    def __init__(self, ekf: PdrEkfEstimator, scale: float):
        self.ekf, self.scale, self.done = ekf, scale, set()

    def handle(self, stream, msg) -> None:
        self.ekf.handle(stream, msg)
        agent = getattr(msg, "agent", None)
        if agent and agent not in self.done and agent in self.ekf.state \
                and self.ekf.state[agent].filt is not None:
            self.ekf.state[agent].filt.reset_scale(self.scale, 1e-4)
            self.done.add(agent)

    def finish(self) -> None:
        self.ekf.finish()


def test_bad_odometry_is_counted_and_skipped(building):
    w = walk([(13.5, 0.0), (13.5, 6.75)], stride=1.3)
    odo = odometry(w)
    bad = Odometry(t=odo[2].t + 0.01, agent="ff1", device="ff1/imu", t_start=odo[2].t,
                   delta=np.array([np.nan, 0.0, 0.0]), dheading=0.0, cov=np.eye(4),
                   position=np.zeros(3), heading=0.0)
    other = Odometry(t=odo[3].t + 0.01, agent="ff1", device="ff1/left", t_start=odo[3].t,
                     delta=np.zeros(3), dheading=0.0, cov=np.eye(4), position=np.zeros(3),
                     heading=0.0)
    _, rec, counts = run(building, odo + [bad, other])
    assert counts["bad_odometry"] == 1 and counts["odometry_other_device"] == 1
    assert np.hypot(*(rec.on("pose")[-1].position[:2] - w.p[-1, :2])) < 0.3
    codes = {d.code for d in rec.on("diagnostics")}
    assert {"bad_odometry", "second_odometry_device"} <= codes


def test_configuration_errors_are_clear(building):
    with pytest.raises(ValueError, match="mode 'pose' needs a position"):
        PdrEkfEstimator.Params.model_validate({"start": {"mode": "pose"}})
    with pytest.raises(ValueError, match="mode 'pose' needs a heading"):
        PdrEkfEstimator.Params.model_validate({"start": {"mode": "pose", "position": (1, 2, 0)}})
    with pytest.raises(ValueError, match="start mode 'truth' is not available"):
        PdrEkfEstimator.Params.model_validate({"start": {"mode": "truth"}})
    ekf, _, _ = make_component(PdrEkfEstimator, {"rfid": {"surveyed": {"T": "nowhere"}}},
                               building=building)
    with pytest.raises(ValueError, match="rfid.surveyed: no tag site 'nowhere'"):
        ekf.start()


def test_is_a_conforming_plugin(building, team):
    _, _, _, msgs = team
    check_plugin(PdrEkfEstimator, building=building, sample_input=[("in", m) for m in msgs[:40]],
                 exclude=known("estimator", "pdr_ekf"))
