"""Issue 15: ORCA confidently wrong where the walls held the track back from its odometry.

On the incident (ff4, no UWB, tuning seeds 110 and 128) the walls held the track for a
few steps (ORCA's blocked steps, a turn slide storing the step as a translation) while
the INS walked on, metres in all; each step's correction was within the contradiction
gate, none widened the covariance, and the pose stayed trusted 3-5 m off. A rule's
correction that no measurement explains now widens the covariance along the move it
made (``drift.correction_doubt``): hand-computed here with stub constraints on
``dead_reckoning``.
"""
from __future__ import annotations

import numpy as np

from firenav_framework.capabilities.odometry_correction import StepCorrection
from tests.orca.test_dead_reckoning import POSE, Teleport, ins_steps, run

#: 10 steps of 1 m east (x 5..15 m, y 8.4 m).
PATH = np.column_stack([5.0 + np.arange(11.0), np.full(11, 8.4)])


class _Hold:
    """Walls that hold the agent where it is from step ``at`` on (no evidence reported)."""

    def __init__(self, at: int):
        self.at, self.n = at, 0

    def correct(self, step):
        self.n += 1
        return None if self.n < self.at else StepCorrection(position=step.prev.copy(),
                                                             event="hold")


def _poses(constraint, doubt: float):
    rec, counts = run({**POSE, "drift": {"correction_doubt": doubt}}, ins_steps(PATH),
                      constraints=[constraint])
    return rec.on("pose"), counts


def test_each_step_the_walls_hold_back_widens_by_its_square_along_it():
    """Held from the fifth step on: each held step moves the agent 1 m back against the
    odometry (east), so the covariance is that of the same run without the doubt plus
    k m^2 along x after k held steps, nothing across; the walls held the track 3 m from
    its odometry by the seventh step and the pose is no longer trusted (sigma_x >= 1.7 m,
    radius > 5 m); without the doubt it stays trusted 6 m behind the odometry."""
    held, counts = _poses(_Hold(5), 1.0)
    bare, _ = _poses(_Hold(5), 0.0)
    assert "odometry_contradicted" not in counts
    for k, (p, q) in enumerate(zip(held, bare), 1):
        extra = max(k - 4, 0)
        np.testing.assert_allclose(p.position, q.position, atol=1e-12)
        np.testing.assert_allclose(p.cov[0, 0] - q.cov[0, 0], extra, atol=1e-9)
        np.testing.assert_allclose(p.cov[1, 1] - q.cov[1, 1], 0.0, atol=1e-12)
        np.testing.assert_allclose(p.cov[0, 1] - q.cov[0, 1], 0.0, atol=1e-12)
    np.testing.assert_allclose(held[-1].position[:2], PATH[4], atol=1e-9)
    assert held[3].trusted and not any(p.trusted for p in held[6:])
    assert all(p.trusted for p in bare)


def test_a_correction_a_measurement_explains_is_not_widened():
    """A 0.5 m shift north at step 4: explained by a measurement (anchor_range's Kalman
    update) it leaves the covariance as without the doubt; made by a rule it adds
    0.25 m^2 along y."""
    explained, _ = _poses(Teleport(4, (0.0, 0.5), keep=True, explained=True), 1.0)
    ruled, _ = _poses(Teleport(4, (0.0, 0.5), keep=True), 1.0)
    bare, _ = _poses(Teleport(4, (0.0, 0.5), keep=True), 0.0)
    for p, q in zip(explained, bare):
        np.testing.assert_allclose(p.cov, q.cov, atol=1e-12)
    np.testing.assert_allclose(ruled[3].cov[1, 1] - bare[3].cov[1, 1], 0.25, atol=1e-9)
    np.testing.assert_allclose(ruled[3].cov[0, 0] - bare[3].cov[0, 0], 0.0, atol=1e-12)
