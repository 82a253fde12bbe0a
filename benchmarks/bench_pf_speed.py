"""Particle-filter speed: real-time factor with wall crossing and search-pattern updates.

The ``particle_filter`` estimator with its ``wall_crossing`` and ``search_pattern_icp``
constraints, at the paper's rates (search-pattern paper §V-B: odometry at 2 Hz, a
pattern comparison every 2 m walked over the last 20 m, q = 10 % pseudo-observation
resampling), is fed the odometry of firefighters searching a bundled plan (right-hand
searches with a drifting INS, starting at different places, unknown start). Reported:

* real-time factor = simulated seconds / wall seconds, for 1 and for 10 firefighters
  handled at once by one filter, at 500 and 5 000 particles per firefighter;
* the same for a straightforward reference in the same run: one Python ICP call per
  (pattern, rotation) with a KD-tree over the densified pattern and numpy Kabsch, and
  the all-pairs numpy wall test of ``bench_wall_crossing.py``.

Goals (issue 6): >= 100x real time at 500 particles for one firefighter; >= 1x (real
time) for 10 firefighters at 5 000 particles each. Run:

    .venv/bin/python benchmarks/bench_pf_speed.py [--plan flat_125] [--minutes 5]
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench_wall_crossing import numpy_all_pairs  # noqa: E402

from firenav_framework.building import bundled_plan, load_building  # noqa: E402
from firenav_framework.building.search_patterns import extract_search_patterns  # noqa: E402
from firenav_framework.testing import make_component  # noqa: E402
from firenav_plugins.constraints.search_pattern_icp import SearchPatternIcpConstraint  # noqa: E402
from firenav_plugins.constraints.search_pattern_icp.comparison import (  # noqa: E402
    Observations, PatternComparison)
from firenav_plugins.constraints.search_pattern_icp.principal import principal_rotation  # noqa: E402
from firenav_plugins.constraints.wall_crossing import WallCrossingConstraint  # noqa: E402
from firenav_plugins.estimators.particle_filter import ParticleFilterEstimator  # noqa: E402
from tests.pf.synthetic import drifting_walk  # noqa: E402


# ----------------------------------------------------------------------------- reference
def _kabsch(x: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    xm, qm = x.mean(0), q.mean(0)
    u, _, vt = np.linalg.svd((x - xm).T @ (q - qm))
    d = np.sign(np.linalg.det(vt.T @ u.T))
    r = vt.T @ np.diag([1.0, d]) @ u.T
    return r, qm - r @ xm


def icp_reference(src: np.ndarray, pattern: np.ndarray, theta0: float, max_iter: int = 30,
                  tol: float = 1e-4, step: float = 0.02) -> tuple[float, np.ndarray, np.ndarray]:
    """Textbook point-to-point ICP against the pattern densified every ``step`` metres."""
    seg = np.diff(pattern, axis=0)
    n = np.maximum(1, np.ceil(np.hypot(*seg.T) / step)).astype(int)
    dense = np.vstack([pattern[i] + np.outer(np.arange(k) / k, seg[i]) for i, k in enumerate(n)]
                      + [pattern[-1:]])
    tree = cKDTree(dense)
    c, s = math.cos(theta0), math.sin(theta0)
    r = np.array([[c, -s], [s, c]])
    t = dense.mean(0) - r @ src.mean(0)
    prev = math.inf
    for _ in range(max_iter + 1):
        d, j = tree.query(src @ r.T + t)
        rmse = math.sqrt(np.mean(d ** 2))
        if prev - rmse < tol:
            break
        prev = rmse
        r, t = _kabsch(src, dense[j])
    return rmse, r, t


class ReferenceComparison(PatternComparison):
    """Algorithm 1 with one Python ICP call per (pattern, rotation)."""

    def compare(self, odo_xy: np.ndarray) -> Observations:
        k = len(self.sub)
        e = np.full((k, 2), np.inf)
        last = odo_xy[-1]
        for m in range(k):
            pat = self.sub.points[m]
            phi = principal_rotation(odo_xy, self.patterns.angle[int(self.sub.floor[m])])
            for i in range(4):
                rmse, r, t = icp_reference(odo_xy, pat, phi + i * math.pi / 2,
                                           self.max_iter, self.tol)
                xt = r @ last + t
                col = int(np.hypot(*(xt - pat[0])) >= np.hypot(*(xt - pat[-1])))
                e[m, col] = min(e[m, col], rmse)
        return Observations(position=self.entry_position, heading=self.entry_heading,
                            rmse=e.reshape(-1), floor=self.entry_floor)


class ReferenceIcp(SearchPatternIcpConstraint):
    name = "search_pattern_icp_reference"

    @property
    def comparison(self) -> PatternComparison:
        if self._comparison is None:
            sp = extract_search_patterns(self.ctx.building, spacing=self.params.grid_spacing_m)
            self._comparison = ReferenceComparison(sp, self.params.length_m)
        return self._comparison


class ReferenceWalls(WallCrossingConstraint):
    name = "wall_crossing_reference"

    def log_likelihood(self, step):
        crossed = np.zeros(len(step.particles), bool)
        for fl in np.unique(step.before.floor):
            sel = step.before.floor == fl
            crossed[sel] = numpy_all_pairs(step.before.xy[sel], step.particles.xy[sel],
                                           step.building.floors[int(fl)].walls)
        return np.where(crossed, -math.inf, 0.0)


# ----------------------------------------------------------------------------- workload
def walks(building, n_ff: int, minutes: float) -> list:
    """``n_ff`` right-hand searches of ``minutes`` each, starting at different nodes."""
    sp = extract_search_patterns(building)
    loop = sp.positions(sp.sequence("right_hand"))
    out = []
    for k in range(n_ff):
        start = (k * len(loop)) // max(n_ff, 1)
        ring = np.roll(loop, -start, axis=0)
        laps = int(math.ceil(minutes * 60 * 0.6 / len(ring))) + 1
        w = drifting_walk(np.vstack([ring] * laps), seed=k, agent=f"ff{k + 1}")
        keep = [o for o in w.odometry if o.t <= minutes * 60]
        out.append(keep)
    return out


def run(building, odometry: list, particles: int, reference: bool) -> tuple[float, float, dict]:
    """(simulated seconds, wall seconds, counts) of one filter over all agents' odometry."""
    pf, rec, stats = make_component(ParticleFilterEstimator, {"particles": particles, "start": {"mode": "unknown"}},
                                    building=building)
    walls_cls, icp_cls = ((ReferenceWalls, ReferenceIcp) if reference else
                          (WallCrossingConstraint, SearchPatternIcpConstraint))
    all_stats = [stats]
    for cls, cid in ((walls_cls, "walls"), (icp_cls, "icp")):
        c, _, cstats = make_component(cls, {}, building=building, cid=cid)
        c.start()
        pf.constraints.append(c)
        all_stats.append(cstats)
    msgs = sorted((m for agent in odometry for m in agent), key=lambda m: m.t)
    t0 = time.perf_counter()
    for m in msgs:
        pf.handle("odo", m)
    wall = time.perf_counter() - t0
    sim = max(a[-1].t for a in odometry) - min(a[0].t_start for a in odometry)
    counts = {k: v for st in all_stats for c in st.counts.values() for k, v in c.items()}
    return sim, wall, counts


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plan", default="flat_125")
    ap.add_argument("--minutes", type=float, default=5.0, help="simulated search per firefighter")
    ap.add_argument("--reference-minutes", type=float, default=2.0,
                    help="simulated minutes for the (slow) reference")
    args = ap.parse_args()
    building = load_building(bundled_plan(args.plan))
    # warm up the compiled kernels so that compilation is not timed
    run(building, walks(building, 1, 0.7), 100, reference=False)
    rows = []
    for particles in (500, 5000):
        for n_ff in (1, 10):
            sim, wall, counts = run(building, walks(building, n_ff, args.minutes), particles, False)
            rows.append(("ours", particles, n_ff, sim, wall, counts.get("comparisons", 0)))
            if n_ff == 1:
                sim_r, wall_r, counts_r = run(building, walks(building, 1, args.reference_minutes),
                                              particles, True)
                rows.append(("reference", particles, n_ff, sim_r, wall_r,
                             counts_r.get("comparisons", 0)))
    print(f"plan {args.plan}; real-time factor = simulated time / wall time "
          f"(10 firefighters: all processed together)")
    print(f"{'impl':<10} {'particles':>9} {'firefighters':>12} {'sim [s]':>8} {'wall [s]':>9} "
          f"{'comparisons':>11} {'RT factor':>10}")
    for impl, particles, n_ff, sim, wall, comps in rows:
        print(f"{impl:<10} {particles:>9} {n_ff:>12} {sim:>8.0f} {wall:>9.2f} {comps:>11} "
              f"{sim / wall:>9.1f}x")
    goal1 = next(r for r in rows if r[:3] == ("ours", 500, 1))
    goal2 = next(r for r in rows if r[:3] == ("ours", 5000, 10))
    print(f"goal >= 100x at 500 particles, 1 firefighter: {goal1[3] / goal1[4]:.0f}x "
          f"({'met' if goal1[3] / goal1[4] >= 100 else 'NOT met'})")
    print(f"goal >= 1x at 5000 particles, 10 firefighters: {goal2[3] / goal2[4]:.1f}x "
          f"({'met' if goal2[3] / goal2[4] >= 1 else 'NOT met'})")


if __name__ == "__main__":
    main()
