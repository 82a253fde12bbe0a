"""anchor_range: UWB ranges to a fixed anchor correct the dead-reckoned position."""
from __future__ import annotations

import math

import numpy as np
import pytest

from firenav_framework.building import Anchor
from firenav_framework.testing import check_plugin
from firenav_plugins.constraints.anchor_range import AnchorRangeConstraint
from firenav_plugins.constraints.anchor_range.constraint import MAX_PENDING
from tests.orca.walker import Walker, building

ANCHOR = Anchor("uwb_start", "uwb", np.array([0.0, 0.0, 1.0]), 0)
TAG = 1.4        # tag height above the floor [m] (the constraint's default)
FAR = [[[-50.0, -20.0], [50.0, -20.0]]]      # a floor whose only wall is out of the way


def true_range(x: float, y: float = 0.0) -> float:
    return math.sqrt(x * x + y * y + (TAG - ANCHOR.position[2]) ** 2)


def walker(walls=FAR, start=(2.0, 0.0), **params) -> Walker:
    return Walker(building(walls, anchors=[ANCHOR]), start, 0.0,
                  extra=[(AnchorRangeConstraint, params)])


def test_ranges_take_out_a_short_stride_along_the_line_to_the_anchor():
    """The INS measures each 1.3 m stride 5 % short while walking straight away from the
    anchor; a true range after every step keeps the along-track error near the Kalman
    filter's steady-state lag (about 0.13 m) instead of 5 % of the distance, and never
    moves the track sideways (the range says nothing across the line of sight)."""
    w = walker()
    x_true = 2.0
    for _ in range(30):
        end = w.step(0.95 * 1.3, 0.0)
        x_true += 1.3
        w.range("uwb_start", true_range(x_true), sigma=0.05)
    end = w.step(0.95 * 1.3, 0.0)
    x_true += 1.3
    ins_error = 31 * 0.05 * 1.3
    assert abs(end[0] - x_true) < 0.25 < 0.2 * ins_error
    assert end[1] == pytest.approx(0.0, abs=1e-12)
    assert w.counts()["ranges_used"] == 30


def test_a_range_is_taken_where_the_agent_was_at_its_time():
    """A range halfway through a 2 m step is compared with the position interpolated
    there: a true range there leaves the step alone."""
    w = walker()
    w.step(2.0, 0.0)                                  # at x = 4 (t = 1)
    w.range("uwb_start", true_range(5.0), dt=0.5)     # at x = 5 (t = 1.5)
    end = w.step(2.0, 0.0)                            # to x = 6 (t = 2)
    assert w.counts()["ranges_used"] == 1
    np.testing.assert_allclose(end[:2], [6.0, 0.0], atol=1e-9)


@pytest.mark.parametrize("case, count", [
    ("nlos", "ranges_nlos"), ("unknown", "ranges_unknown_anchor"),
    ("nan", "ranges_invalid"), ("negative", "ranges_invalid"), ("outlier", "ranges_gated"),
    ("wall", "ranges_through_walls"), ("stale", "ranges_stale"),
    ("close", "ranges_too_close"),
])
def test_unusable_ranges_are_counted_and_leave_the_track_alone(case, count):
    walls = FAR + [[[3.0, -5.0], [3.0, 5.0]]] if case == "wall" else FAR
    start = (0.3, 0.0) if case == "close" else (5.0, 0.0)
    w = walker(walls, start=start)
    w.step(0.5, 0.0)
    x = start[0] + 0.5
    r = {"nan": float("nan"), "negative": -1.0, "outlier": true_range(x) + 5.0}.get(
        case, true_range(x) + 0.4)
    w.range("ghost" if case == "unknown" else "uwb_start", r, nlos=case == "nlos")
    end = w.step(0.5, 0.0, dt=5.0 if case == "stale" else 1.0)
    counts = w.counts()
    assert counts.get(count) == 1 and "ranges_used" not in counts and "anchor_range" not in counts
    np.testing.assert_allclose(end[:2], [x + 0.5, 0.0], atol=1e-12)


def test_nlos_ranges_are_used_when_asked():
    w = walker(use_nlos=True)
    w.step(0.5, 0.0)
    w.range("uwb_start", true_range(2.5) + 0.4, nlos=True)
    end = w.step(0.5, 0.0)
    assert w.counts()["ranges_used"] == 1 and end[0] > 3.0


def test_ranges_waiting_for_a_step_do_not_pile_up():
    """Standing still (no steps) at 10 Hz for longer than the pending store holds: the
    oldest are dropped as stale; the next step uses those of the last max_age seconds
    and counts the rest stale."""
    w = walker()
    w.step(0.5, 0.0)
    n = MAX_PENDING + 50
    for k in range(n):
        w.range("uwb_start", true_range(2.5), dt=0.1 * k)
    me = w.constraints[0][0].agents["ff1"]
    assert len(me.pending) == MAX_PENDING and w.counts()["ranges_stale"] == 50
    w.step(0.0, 0.0, dt=0.1 * n)
    counts = w.counts()
    assert not me.pending
    assert counts["ranges_used"] + counts.get("ranges_gated", 0) == 20     # the last 2 s
    assert counts["ranges_stale"] == n - 20


def test_ranges_that_arrive_before_their_steps_wait_for_them():
    """Issue 15: dead_reckoning holds its first steps back until it is aligned (about
    12 s of a run) and then delivers them with their own times, after the ranges of the
    same seconds have arrived. A range is aged against its step, not against the newest
    range (which dropped all but the last 2 s of them as stale)."""
    w = walker()
    for k in range(10):                  # walking 1 m/s from x = 2: x = 2.5 + k at t
        w.range("uwb_start", true_range(2.5 + k), dt=0.5 + k)
    for _ in range(10):
        w.step(1.0, 0.0)
    counts = w.counts()
    assert counts["ranges_used"] == 10 and "ranges_stale" not in counts


def test_it_is_a_conforming_plugin():
    check_plugin(AnchorRangeConstraint)


def test_nearly_collinear_ranges_claim_no_more_across_their_line_than_they_know():
    """Two ranges 2 degrees apart in direction (sigma 0.18 m each) pin the position along
    their line, but across it they know only what their least-squares fix knows: the
    filter's own tight covariance (its step model, not the radio) must not be reported
    as the radio's evidence there."""
    from firenav_plugins.constraints.anchor_range.constraint import _seen
    sigma, a = 0.18, math.radians(2.0)
    h = np.array([[1.0, 0.0], [math.cos(a), math.sin(a)]])
    info = h.T @ h / sigma ** 2
    filter_cov, floor = np.diag([0.01, 0.01]), 0.15 ** 2
    cov = _seen(filter_cov, info, floor)
    ls = np.linalg.inv(info)                    # what the two ranges alone know
    values, axes = np.linalg.eigh(info)
    across, along = axes[:, 0], axes[:, 1]
    assert across @ cov @ across == pytest.approx(1.0 / values[0])
    assert across @ cov @ across == pytest.approx(across @ ls @ across)   # metres, not cm
    assert across @ cov @ across > 10.0
    # along their line the filter (plus the model floor) knows better than one step's ranges
    assert along @ cov @ along == pytest.approx(0.01 + floor)


def test_ranges_from_an_anchor_on_another_floor_are_counted_and_not_used():
    """An anchor on the floor above (its range through the slab, 0.4 m long): no wall of
    the walker's floor crosses the line, but the range is left out and counted; with
    ``other_floors`` it is used."""
    from firenav_framework.building import Building, Floor
    upstairs = Anchor("uwb_up", "uwb", np.array([0.0, 0.0, 4.0]), 1)
    floors = [Floor(index=k, z=3.0 * k, height=3.0, walls=np.array(FAR, float), doors=[])
              for k in (0, 1)]
    for other_floors in (False, True):
        w = Walker(Building("two", floors, anchors=[upstairs]), (5.0, 0.0), 0.0,
                   extra=[(AnchorRangeConstraint, {"other_floors": other_floors})])
        w.step(0.5, 0.0)
        r = math.sqrt(5.5 ** 2 + (TAG - 4.0) ** 2) + 0.4
        w.range("uwb_up", r)
        end = w.step(0.5, 0.0)
        counts = w.counts()
        if other_floors:
            assert counts["ranges_used"] == 1 and end[0] > 6.1     # pushed off by the bias
        else:
            assert counts.get("ranges_other_floor") == 1 and "ranges_used" not in counts
            np.testing.assert_allclose(end[:2], [6.0, 0.0], atol=1e-12)


@pytest.mark.parametrize("walls", [FAR, FAR + [[[8.0, -5.0], [8.0, 5.0]]]], ids=["open", "wall"])
def test_ranges_too_short_for_the_position_move_it_onto_their_circle(walls):
    """Issue 15: the track starts 10 m too far from the anchor with a tight covariance;
    the true ranges are 10 m shorter than its prediction, far outside the gate, and (in
    the second case) cross a wall of the plan from the wrong position. A range can only
    be lengthened by walls, so two of them in a row say the position is wrong: the first
    is counted, the second moves the position onto its circle (the estimator widens the
    pose by the move) and warns; the next true range is used as usual."""
    w = walker(walls, start=(12.0, 0.0))
    w.step(0.5, 0.0)                            # believed 12.5, truly 2.5
    w.range("uwb_start", true_range(2.5))
    stuck = w.step(0.5, 0.0)
    assert stuck[0] == pytest.approx(13.0) and w.counts()["ranges_short"] == 1
    w.range("uwb_start", true_range(3.0))
    moved = w.step(0.5, 0.0)
    np.testing.assert_allclose(moved[:2], [3.5, 0.0], atol=1e-9)
    counts = w.counts()
    assert counts["anchor_relocation"] == 1 and "anchor_range" not in counts
    pose = w.rec.on("pose")[-1]
    assert np.linalg.eigvalsh(np.asarray(pose.cov)[:2, :2]).min() > 9.5 ** 2   # the 10 m move
    assert [d.code for d in w.constraint_records[0].on("diagnostics")
            if d.level == "warning"] == ["anchor_relocation"]
    w.range("uwb_start", true_range(3.5) + 0.05)
    w.step(0.5, 0.0)
    assert w.counts()["ranges_used"] == 2



@pytest.mark.parametrize("short, params", [(10.0, {"relocate_after": 0}), (1.5, {})],
                         ids=["relocation off", "within the margin"])
def test_short_ranges_are_gated_when_relocation_is_off_or_within_the_margin(short, params):
    """Ranges far beyond the gate of a tight track, shorter than predicted: with relocation
    off, or short by less than what the noise of a range through walls reaches
    (relocate_margin 2 m), they are dropped as gated and the track keeps its course."""
    w = walker(start=(12.0, 0.0), **params)
    for k in range(4):
        w.step(0.5, 0.0)
        w.range("uwb_start", true_range(12.5 + 0.5 * k) - short)
    end = w.step(0.5, 0.0)
    assert end[0] == pytest.approx(14.5)
    assert w.counts()["ranges_gated"] == 4 and "anchor_relocation" not in w.counts()


def test_a_range_that_puts_the_walker_beside_the_anchor_pulls_the_track_to_it():
    """Issue 15: standing 0.3 m from the anchor (range 0.5 m, the tag 0.4 m above it),
    the track believed 0.9 m from it on the other side, inside min_distance, where the
    bearing is unknown. Each range says "within 0.55 m of the anchor" (one sigma long):
    a fix at the anchor that brings the filter's variance down to that disc and no lower,
    range after range; the track ends within the disc, where before it stayed 1.2 m off."""
    w = walker(start=(0.9, 0.0))
    r = math.hypot(0.3, TAG - ANCHOR.position[2])
    for _ in range(20):
        w.range("uwb_start", r)
        end = w.step(0.0, 0.0)
    disc = (r + math.hypot(0.1, 0.15)) ** 2 - (TAG - ANCHOR.position[2]) ** 2
    assert np.hypot(*end[:2]) < 0.1 and np.hypot(end[0] + 0.3, end[1]) < math.sqrt(disc)
    assert w.counts()["ranges_near"] == 20 and "ranges_too_close" not in w.counts()
    me = w.constraints[0][0].agents["ff1"]
    assert np.linalg.eigvalsh(me.cov).min() == pytest.approx(disc)


def test_ranges_out_of_time_order_are_counted_and_taken_in_order():
    w = walker()
    w.step(1.0, 0.0)                                      # at x = 3 (t = 1)
    w.range("uwb_start", true_range(3.9), dt=0.9)
    w.range("uwb_start", true_range(3.2), dt=0.2)        # the earlier one, late
    me = w.constraints[0][0].agents["ff1"]
    assert [round(e[0], 1) for e in me.pending] == [1.2, 1.9]
    end = w.step(1.0, 0.0)
    assert w.counts()["ranges_out_of_order"] == 1 and w.counts()["ranges_used"] == 2
    np.testing.assert_allclose(end[:2], [4.0, 0.0], atol=1e-9)
