"""``pipelines/incident.yaml``'s team_fusion settings on a synthetic walk with known
errors shaped as the methods' on the incident's tuning seeds (docs/team-fusion.md): the
inputs that dead-reckon the same strides as INS alone (ORCA + UWB taking on the INS
drift away from the anchor, with a covariance that holds it; the particle filter) must
not out-vote the tag-aided EKF, and the fused pose is trusted where the EKF and a
second input bound it, never while more than the alert limit off. Only the streams the
pipeline gives team_fusion are fed, with its settings (INS alone's pose only votes a floor)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import yaml

from firenav_framework import Odometry, PoseEstimate
from firenav_framework.testing import Session
from firenav_plugins.estimators.team_fusion import TeamFusionEstimator

PIPELINE = Path(__file__).resolve().parents[2] / "pipelines" / "incident.yaml"


def _team() -> tuple[dict, set[str]]:
    """team_fusion's parameters in the pipeline and the streams it is given."""
    spec = yaml.safe_load(PIPELINE.read_text())
    team = next(e for e in spec["estimators"] if e["plugin"] == "team_fusion")
    return {k: v for k, v in team.items() if k not in ("id", "plugin", "input")}, set(team["input"])


def _pose(t: float, xy: np.ndarray, sigma: float) -> PoseEstimate:
    return PoseEstimate(t=t, agent="ff1", device="ff1/imu",
                        position=np.array([xy[0], xy[1], 0.0]), heading=0.0,
                        cov=np.diag([sigma ** 2, sigma ** 2, 0.01, 0.01]), floor=0)


def _walk(seed: int) -> tuple[list, np.ndarray, np.ndarray]:
    """400 strides of 0.75 m each 1 s, turning at random; INS alone drifts (a heading
    error growing with time); each method's pose published after the odometry of
    its stride, as the methods do. Returns the messages, the truth (n, 2) and the EKF's
    positions (n, 2)."""
    rng = np.random.default_rng(seed)
    n = 400
    heading = np.cumsum(rng.normal(0.0, 0.08, n))
    step = 0.75 * np.c_[np.cos(heading), np.sin(heading)]
    truth = np.cumsum(step, axis=0)
    bias = 0.0005 * np.arange(1, n + 1) + np.cumsum(rng.normal(0.0, 0.002, n))  # [rad] INS heading error
    c, s = np.cos(bias), np.sin(bias)
    ins = np.cumsum(np.c_[c * step[:, 0] - s * step[:, 1], s * step[:, 0] + c * step[:, 1]],
                    axis=0)
    drift = ins - truth
    # INS alone: its covariance as published (team_fusion's `inflate` makes it honest)
    sigma_dr = 0.3 + 0.05 * np.arange(1, n + 1) ** 0.8
    msgs, ekf = [], np.empty((n, 2))
    for k in range(n):
        t = float(k + 1)
        msgs.append(("dr.odometry", Odometry(
            t=t, agent="ff1", device="ff1/imu", t_start=t - 1.0,
            delta=np.array([0.75, 0.0, 0.0]), dheading=0.0, cov=np.eye(4) * 1e-4,
            position=np.array([ins[k, 0], ins[k, 1], 0.0]), heading=float(heading[k] + bias[k]))))
        msgs.append(("dr.pose", _pose(t, ins[k], sigma_dr[k])))
        # ORCA + UWB: right near the anchor at the entrance (the first 60 strides), then
        # taking on 80 % of the INS drift from there, its 1-sigma growing with that error
        share = 0.0 if k < 60 else 0.8 * min(1.0, (k - 60) / 60)
        err = share * (drift[k] - drift[60])
        msgs.append(("mm.pose", _pose(t, truth[k] + err, 0.5 + 0.7 * float(np.hypot(*err)))))
        # the particle filter: corrects 40 %, claims a few metres
        msgs.append(("pf.pose", _pose(t, truth[k] + 0.6 * drift[k] + rng.normal(0, 0.5, 2), 2.0)))
        # the tag-aided EKF: honest, 0.8 m
        ekf[k] = truth[k] + rng.normal(0.0, 0.8, 2)
        msgs.append(("ekf.pose", _pose(t, ekf[k], 0.8)))
    return msgs, truth, ekf


def _rmse(xy: np.ndarray, truth: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum((xy - truth) ** 2, axis=1))))


def _fused(seed: int) -> tuple[list, np.ndarray, np.ndarray, np.ndarray]:
    """The walk of ``seed`` through team_fusion with the incident's settings: the fused
    poses at the strides published (a corrected step: its last), the truth and the EKF
    there."""
    msgs, truth, ekf = _walk(seed)
    params, streams = _team()
    rec = Session(TeamFusionEstimator, params).run([m for m in msgs if m[0] in streams])
    last = {round(p.t, 6): p for p in rec.on("pose")}
    keep = [k for k in range(len(truth)) if round(float(k + 1), 6) in last]
    assert len(keep) >= len(truth) - 2
    return [last[round(float(k + 1), 6)] for k in keep], truth[keep], ekf[keep], msgs


def test_inputs_sharing_the_drift_do_not_outvote_the_tag_fixes():
    for seed in (1, 2, 3):
        poses, truth, ekf, msgs = _fused(seed)
        fused = np.array([p.position[:2] for p in poses])
        mm = np.array([m.position[:2] for s, m in msgs if s == "mm.pose"])
        assert _rmse(mm, _walk(seed)[1]) > 5.0      # ORCA + UWB far off away from the anchor
        assert _rmse(fused, truth) <= 1.1 * _rmse(ekf, truth)


def test_trusted_where_the_tag_fixes_and_a_second_input_bound_the_pose():
    """Trusted needs the fused 99 % radius within the alert limit (3 m) and two inputs
    each within `support.radius` on their own: here the EKF (2.4 m) and ORCA + UWB near
    the anchor and while its drift is small. Never trusted while more than 3 m off."""
    for seed in (1, 2, 3):
        poses, truth, _, _ = _fused(seed)
        err = np.hypot(*(np.array([p.position[:2] for p in poses]) - truth).T)
        trusted = np.array([p.trusted for p in poses])
        assert not np.any(trusted & (err > 3.0))
        assert trusted[:60].mean() > 0.5            # near the anchor: two tight inputs
        assert trusted.mean() > 0.15
