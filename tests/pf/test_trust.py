"""The filter's integrity: the protection radius of the cloud and the plan-contradiction
monitor (:mod:`firenav_plugins.estimators.particle_filter.trust`)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from firenav_framework.capabilities import Particles
from firenav_plugins.estimators.particle_filter.trust import (
    ContradictionMonitor, DoubtMonitor, JumpMonitor, PlanEvidenceMonitor, cloud_protection_radius,
    retained_fraction)

K99 = math.sqrt(-2.0 * math.log(0.01))   # 99 % radius of a unit 2-D Gaussian


def test_radius_of_a_point_cloud_is_the_kernel_radius():
    p = Particles.create(np.zeros((100, 2)), 0.0)
    assert cloud_protection_radius(p, np.zeros(2), 0, 0.99, 0.5) == pytest.approx(0.5 * K99)


def test_a_second_cluster_widens_the_radius_in_full():
    xy = np.vstack([np.zeros((95, 2)), np.full((5, 2), [8.0, 0.0])])
    p = Particles.create(xy, 0.0)
    mean = p.weights @ p.xy                       # (0.4, 0): between the two
    r = cloud_protection_radius(p, mean, 0, 0.99, 0.0)
    assert r == pytest.approx(7.6)                # the far cluster's 5 % count
    assert cloud_protection_radius(p, mean, 0, 0.90, 0.0) == pytest.approx(0.4)


def test_weight_on_another_floor_gives_no_bound():
    p = Particles.create(np.zeros((100, 2)), 0.0, floor=np.r_[np.zeros(98), np.ones(2)])
    assert math.isinf(cloud_protection_radius(p, np.zeros(2), 0, 0.99, 0.5))
    assert math.isfinite(cloud_protection_radius(p, np.zeros(2), 0, 0.97, 0.5))


def test_retained_fraction():
    logw = np.log(np.full(4, 0.25))
    assert retained_fraction(logw, np.zeros(4)) == pytest.approx(1.0)
    assert retained_fraction(logw, np.array([0, 0, -np.inf, -np.inf])) == pytest.approx(0.5)
    assert retained_fraction(logw, np.log([1.0, 0.1, 0.1, 0.1])) == pytest.approx(0.325)
    assert retained_fraction(logw, np.full(4, -np.inf)) == 0.0


def test_monitor_fires_once_holds_and_clears():
    m = ContradictionMonitor(floor=0.25, smoothing=0.5, hold_s=10.0)
    starts = [m.update(float(t), 0.0) for t in range(4)]     # level 0.5, 0.25, 0.125, ...
    assert starts == [False, False, True, False] and m.contradicted
    for t in range(4, 12):
        m.update(float(t), 1.0)
    assert m.contradicted                 # recovered level, but within hold of t=3
    m.update(14.0, 1.0)
    assert not m.contradicted


def test_jump_monitor_sums_shifts_over_the_window_and_waits_for_evidence():
    m = JumpMonitor(jump_m=2.0, evidence_m=3.0, window_s=5.0)
    assert not m.awaiting_evidence                          # no jump yet
    # ordinary corrections of a converged cloud: back and forth, they cancel out
    assert not any(m.update(float(t), np.array([0.6 * (-1) ** t, 0.0]), 0.5) for t in range(20))
    # weight passing to a look-alike room 4 m east over four updates: one jump
    hits = [m.update(20.0 + k, np.array([1.0, 0.0]), 0.5) for k in range(4)]
    assert hits == [False, False, True, False] and m.awaiting_evidence
    for k in range(4):                                      # 2.5 m walked: not yet
        m.update(24.0 + k, np.zeros(2), 0.5)
    assert m.awaiting_evidence
    m.update(28.0, np.zeros(2), 0.5)                        # 3.0 m walked since the jump
    assert not m.awaiting_evidence
    # shifts further apart than the window do not add up
    assert not any(m.update(40.0 + 6 * k, np.array([1.5, 0.0]), 0.5) for k in range(5))


def test_plan_evidence_multiplies_the_retained_shares_over_the_window():
    """Half the cloud refuted at every update never takes the smoothed level below the
    contradiction monitor's floor, but the product over the last metres walked does."""
    smoothed = ContradictionMonitor(floor=0.25, smoothing=0.3, hold_s=10.0)
    ev = PlanEvidenceMonitor(floor=0.05, window_m=3.0)
    assert not ev.update(1.0, 1.0) and not ev.update(1.0, 1.0)        # nothing refuted
    hits = []
    for _ in range(8):                                               # 0.5 per metre walked
        smoothed.update(0.0, 0.5)
        hits.append(ev.update(0.5, 1.0))
    assert not smoothed.contradicted
    # the window holds the updates up to 3 m back: four of 1 m steps, 0.5^4 = 0.0625 > 0.05
    assert not any(hits)
    ev = PlanEvidenceMonitor(floor=0.05, window_m=3.0)
    hits = [ev.update(0.5, 0.25) for _ in range(8)]
    assert hits == [False, False, False, False, True, True, True, True]   # 0.5^5 < 0.05
    # the plan agrees again: contradicted until the refuting updates are 3 m behind
    after = [ev.update(1.0, 0.25) for _ in range(14)]
    assert after[:8] == [True] * 8 and not any(after[-2:])
    assert ev.update(0.0, 0.25)                                       # everything refuted


def test_doubt_monitor_waits_for_evidence_and_grows_while_untrusted():
    m = DoubtMonitor(evidence_m=2.0, growth=0.1)
    m.update(1.0, contradicted=False)
    assert not m.awaiting_evidence and m.published(True) == 0.0     # no contradiction yet
    m.update(1.0, contradicted=True)
    assert m.awaiting_evidence and m.published(False) == pytest.approx(0.1)
    m.update(1.5, contradicted=False)
    assert m.awaiting_evidence and m.published(False) == pytest.approx(0.25)
    m.update(1.0, contradicted=False)                 # 2.5 m since the contradiction
    assert not m.awaiting_evidence
    assert m.published(True) == 0.0                   # trusted again: no growth
    m.update(3.0, contradicted=False)
    assert m.published(False) == pytest.approx(0.3)   # counted from the last trusted pose


def test_spread_scale_widens_the_clouds_own_radius_not_the_kernel():
    xy = np.vstack([np.zeros((50, 2)), np.full((50, 2), [2.0, 0.0])])
    p = Particles.create(xy, 0.0)
    centre = np.array([1.0, 0.0])
    assert cloud_protection_radius(p, centre, 0, 0.99, 0.0, 1.5) == pytest.approx(1.5)
    assert cloud_protection_radius(p, centre, 0, 0.99, 0.5, 1.5) == pytest.approx(
        math.hypot(1.5, 0.5 * K99))
