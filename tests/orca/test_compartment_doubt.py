"""The compartment doubt: grows with distance walked, narrows only along a range's line,
and only by a range in line of sight of its anchor."""
import math

import numpy as np
import pytest

from firenav_framework import Odometry, Range
from firenav_framework.building import Anchor, Building, Floor
from firenav_framework.capabilities.odometry_correction import OdometryStep
from firenav_framework.geometry import Rigid2D
from firenav_framework.testing import make_component
from firenav_plugins.constraints.orca import OrcaConstraint
from firenav_plugins.constraints.orca.compartment import CompartmentDoubt


def test_sigma_grows_linearly_with_distance_walked():
    d = CompartmentDoubt(0.05)
    for _ in range(100):
        d.walk(1.0)                       # 100 m in 1 m steps
    assert math.isclose(math.sqrt(d.cov[0, 0]), 5.0, rel_tol=1e-9)
    assert math.isclose(math.sqrt(d.cov[1, 1]), 5.0, rel_tol=1e-9)


def test_a_range_narrows_only_along_the_line_to_the_anchor():
    d = CompartmentDoubt(0.05)
    for _ in range(100):
        d.walk(1.0)
    d.range_to(np.array([10.0, 0.0, 0.0]), np.array([0.0, 0.0, 0.0]), 0.5)
    # scalar Kalman update along x: 25 * 0.25 / (25 + 0.25)
    assert math.isclose(d.cov[0, 0], 25 * 0.25 / 25.25, rel_tol=1e-9)
    assert math.isclose(d.cov[1, 1], 25.0, rel_tol=1e-9)


def test_no_growth_keeps_no_doubt():
    d = CompartmentDoubt(0.0)
    d.walk(50.0)
    assert np.all(d.cov == 0.0)


#: A closed 4 m x 4 m room, corners (0, 0) and (4, 4), on two floors (z 0 and 3 m); UWB
#: anchors at tag height: in the room, beyond its east wall, and in the room upstairs.
ROOM = [[[0.0, 0.0], [4.0, 0.0]], [[4.0, 0.0], [4.0, 4.0]], [[4.0, 4.0], [0.0, 4.0]],
        [[0.0, 4.0], [0.0, 0.0]]]
ANCHORS = [Anchor("inside", "uwb", np.array([3.5, 2.0, 1.4]), 0),
           Anchor("beyond", "uwb", np.array([8.0, 2.0, 1.4]), 0),
           Anchor("upstairs", "uwb", np.array([3.5, 2.0, 4.4]), 1)]


def _two_storeys() -> Building:
    floors = [Floor(index=k, z=3.0 * k, height=3.0, walls=np.array(ROOM, float))
              for k in (0, 1)]
    return Building("test", floors, anchors=ANCHORS)


@pytest.mark.parametrize("anchor, nlos, narrows", [
    ("inside", False, True), ("inside", True, False), ("beyond", False, False),
    ("upstairs", False, False)])
def test_only_a_line_of_sight_range_narrows_the_doubt(anchor, nlos, narrows):
    """After 80 m walked with no range (doubt sigma 4 m) the room's walls say nothing of
    the walker in the middle of it. A range to an anchor in the room, in line of sight,
    narrows the doubt along the line to it (x) and the walls hold that axis again; a
    range flagged NLOS, one through the room's wall, or one to an anchor on another floor
    (through the slab) is longer by a bias its sigma does not state and narrows nothing
    (before: every range narrowed it, and the walls held the track upstairs, far from the
    anchor)."""
    c, _, _ = make_component(OrcaConstraint, {}, building=_two_storeys())
    c.start()

    def step(t: float, walked: float):
        odo = Odometry(t=t, agent="ff1", t_start=t - 1.0, delta=np.array([walked, 0.0, 0.0]),
                       dheading=0.0, cov=np.eye(4) * 1e-4, position=np.zeros(3), heading=0.0)
        return c.correct(OdometryStep(agent="ff1", t=t, dt=1.0, prev=np.array([1.85, 2.0, 0.0]),
                                      proposed=np.array([2.15, 2.0, 0.0]), heading=0.0,
                                      transform=Rigid2D(), ins_position=np.zeros(3),
                                      odometry=odo, cov=np.eye(2) * 0.25))

    assert step(1.0, 80.0) is None
    c.handle("uwb", Range(t=1.5, agent="ff1", a="ff1", b=anchor, range_m=1.6, sigma_m=0.1,
                          nlos=nlos))
    fix = step(2.0, 0.3)
    if narrows:
        assert fix is not None and fix.cov[0, 0] == pytest.approx((2.15 ** 3 + 1.85 ** 3) / 12.0)
    else:
        assert fix is None
