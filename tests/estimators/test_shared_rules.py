"""What every built-in estimator shares: the one odometry rule, the one start-pose model
(with each estimator's own defaults and modes), and parameter groups in ``plugins show``."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from pydantic import ValidationError

from firenav_framework import Odometry
from firenav_framework.building import Building, Entrance, Floor
from firenav_framework.cli import main
from firenav_framework.testing import make_component
from firenav_plugins.estimators.breadcrumb_gen import BreadcrumbGenEstimator
from firenav_plugins.estimators.dead_reckoning import DeadReckoningEstimator
from firenav_plugins.estimators.particle_filter import ParticleFilterEstimator
from firenav_plugins.estimators.pdr_ekf import PdrEkfEstimator
from firenav_plugins.estimators.zupt_ins import ZuptInsEstimator

GOOD = Odometry(t=2.0, agent="ff1", device="ff1/imu", t_start=1.0,
                delta=np.array([0.7, 0.0, 0.0]), dheading=0.0, cov=np.eye(4) * 1e-4,
                position=np.array([0.7, 0.0, 0.0]), heading=0.0)
BAD = {
    "delta": dict(delta=np.array([np.nan, 0.0, 0.0])),
    "2-D delta": dict(delta=np.array([0.7, 0.0])),
    "dheading": dict(dheading=math.inf),
    "interval": dict(t_start=9.0),
    "t_start": dict(t_start=math.nan),
    "position": dict(position=np.array([0.0, np.nan, 0.0])),
    "heading": dict(heading=math.nan),
    "covariance": dict(cov=-np.eye(4)),
}


def test_a_good_increment_has_no_problem():
    assert GOOD.problem() == ""


@pytest.mark.parametrize("what", list(BAD))
def test_each_broken_field_is_named(what):
    problem = dataclasses.replace(GOOD, **BAD[what]).problem()
    assert problem, what
    key = {"delta": "increment", "2-D delta": "increment", "dheading": "increment",
           "interval": "interval", "t_start": "interval", "position": "absolute pose",
           "heading": "absolute pose", "covariance": "covariance"}[what]
    assert key in problem


def _building() -> Building:
    walls = np.array([[[-20.0, -20.0], [20.0, -20.0]], [[20.0, -20.0], [20.0, 20.0]],
                      [[20.0, 20.0], [-20.0, 20.0]], [[-20.0, 20.0], [-20.0, -20.0]]])
    return Building("box", [Floor(index=0, z=0.0, height=3.0, walls=walls)],
                    entrances=[Entrance("e", 0, np.array([0.0, 0.0]), 0.0)])


CONSUMERS = [
    (DeadReckoningEstimator, {"start": {"mode": "pose", "position": (0, 0, 0), "heading": 0.0},
                              "imu_yaw_offset": {"angle": 0.0}}),
    (PdrEkfEstimator, {"start": {"mode": "pose", "position": (0, 0, 0), "heading": 0.0},
                       "update_period": None}),
    (ParticleFilterEstimator, {"particles": 20, "update_interval": 0.0,
                               "start": {"mode": "pose", "position": (0, 0, 0), "heading": 0.0}}),
    (BreadcrumbGenEstimator, {"base": {"position": (0.0, 0.0, 0.0)}}),
]


@pytest.mark.parametrize("cls, params", CONSUMERS, ids=lambda c: getattr(c, "name", ""))
def test_every_odometry_consumer_applies_the_same_rule(cls, params):
    """Each broken increment is counted as bad_odometry and reported once; the good ones
    around it still give a pose each."""
    comp, rec, stats = make_component(cls, params, building=_building())
    comp.start()
    later = [dataclasses.replace(GOOD, t=GOOD.t + k, t_start=GOOD.t_start + k,
                                 position=GOOD.delta * (k + 1)) for k in range(3)]
    comp.handle("odo", later[0])
    for k, what in enumerate(BAD):
        comp.handle("odo", dataclasses.replace(later[1], **BAD[what]))
    comp.handle("odo", later[1])
    comp.handle("odo", later[2])
    comp.finish()
    assert stats.counts["under_test"]["bad_odometry"] == len(BAD)
    assert [d.code for d in rec.on("diagnostics")].count("bad_odometry") == 1
    assert len(rec.on("pose")) == 3


def test_a_start_keeps_the_estimators_own_defaults_for_what_it_does_not_say():
    pose = {"mode": "pose", "position": (1.0, 2.0, 0.0), "heading": "90 deg"}
    pf = ParticleFilterEstimator.Params.model_validate({"start": pose}).start
    ekf = PdrEkfEstimator.Params.model_validate({"start": pose}).start
    assert pf.heading == ekf.heading == pytest.approx(math.pi / 2)
    assert (pf.sigma_position, pf.sigma_heading) == pytest.approx((0.1, math.radians(5)))
    assert (ekf.sigma_position, ekf.sigma_heading) == pytest.approx((0.5, math.radians(10)))
    assert PdrEkfEstimator.Params().start.mode == "entrance"
    assert ParticleFilterEstimator.Params().start.mode == "unknown"


@pytest.mark.parametrize("cls, start, message", [
    (ZuptInsEstimator, {"mode": "truth"}, "mode 'truth' is not available"),
    (PdrEkfEstimator, {"mode": "truth"}, "mode 'truth' is not available"),
    (BreadcrumbGenEstimator, {"mode": "entrance"}, "mode 'entrance' is not available"),
    (DeadReckoningEstimator, {"mode": "entrance", "heading": 1.0}, "read only with mode 'pose'"),
    (ZuptInsEstimator, {"mode": "pose", "position": (0, 0, 0)}, "needs a heading"),
    (PdrEkfEstimator, {"mode": "pose", "heading": 0.0}, "needs a position"),
    (ParticleFilterEstimator, {"mode": "pose", "position": (0, 0, 0), "heading": "5 furlongs"},
     "expected a number with a unit"),
])
def test_a_start_an_estimator_cannot_honour_is_refused(cls, start, message):
    with pytest.raises(ValidationError, match=message):
        cls.Params.model_validate({"start": start})


def test_plugins_show_lists_groups_with_dotted_names_units_and_degrees(capsys):
    assert main(["plugins", "show", "zupt_ins"]) == 0
    out = capsys.readouterr().out
    rows = {ln.split()[0]: ln for ln in out.splitlines() if ln and not ln.startswith(" ")}
    assert rows["detector"].split()[1] == "group"
    assert rows["detector.window"].split()[1:4] == ["float", "0.025", "s"]
    assert rows["gravity.latitude"].split()[1:6] == ["float", "or", "none", "None", "rad"]
    assert "(60 deg)" in rows["gait.crawl_tilt"] and " rad " in rows["gait.crawl_tilt"]
    assert rows["start.mode"].split()[:2] == ["start.mode", "one"]
    assert not any(name.endswith(("_deg", "_dps")) for name in rows)


def test_a_misspelt_member_of_a_group_is_located_and_matched_within_its_group():
    from firenav_framework.pipeline import load_pipeline_text
    from firenav_framework.yaml_locations import ConfigError
    text = ("name: t\nsources:\n  - {id: sim, plugin: simulator, scenario: demo}\n"
            "sensors:\n  - {id: imu, plugin: foot_imu, input: sim.imu}\n"
            "estimators:\n  - id: ins\n    plugin: zupt_ins\n    input: imu.imu\n"
            "    detector: {windw: 0.03}\n")
    with pytest.raises(ConfigError) as err:
        load_pipeline_text(text, file="p.yaml")
    assert "p.yaml:10:16: estimators[0].detector.windw: unknown parameter; did you mean " \
           "'window'" in str(err.value)


def test_normal_gravity_at_a_latitude_given_in_degrees_matches_wgs84():
    """WGS-84 normal gravity: 9.7803 m/s^2 at the equator, 9.8322 at the pole, 9.8127 at
    52.2 deg N (Somigliana); the YAML may give the latitude with a unit."""
    from firenav_plugins.estimators.zupt_ins.params import ZuptInsParams
    g = {lat: ZuptInsParams.model_validate({"gravity": {"latitude": lat}}).gravity.g
         for lat in ("0 deg", "90 deg", "52.2 deg")}
    assert g["0 deg"] == pytest.approx(9.78033, abs=1e-5)
    assert g["90 deg"] == pytest.approx(9.83218, abs=1e-5)
    assert g["52.2 deg"] == pytest.approx(9.8127, abs=2e-4)
    with pytest.raises(ValidationError):
        ZuptInsParams.model_validate({"gravity": {"latitude": 52.2}})   # radians: > pi/2
