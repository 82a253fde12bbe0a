"""Particle-filter speed: real-time factor with wall crossing and search-pattern updates.

The ``particle_filter`` estimator with its ``wall_crossing`` and ``search_pattern_icp``
constraints, at the paper's rates (search-pattern paper §V-B: odometry at 2 Hz, a
pattern comparison every 2 m walked over the last 20 m, q = 10 % pseudo-observation
resampling), is fed the odometry of firefighters searching a bundled plan (right-hand
searches with a drifting INS, starting at different places, unknown start). Reported:

* real-time factor = simulated seconds / wall seconds (and CPU seconds of this
  process), for 1 and for 10 firefighters handled at once by one filter, at 500 and
  5 000 particles per firefighter, with walls and search patterns;
* the peer, walls only, beside ours with walls only on the same odometry: Stone Soup's
  particle filter (``ParticlePredictor`` with an odometry transition model,
  ``ParticleUpdater`` with its ``constraint_func`` giving particles whose step crosses a
  wall zero weight, tested with shapely 2's vectorised ``intersects`` against the
  floor's walls, ``ESSResampler``), one firefighter (install the benchmark extra:
  ``pip install -e '.[bench]'``);
* a straightforward search-pattern reference in the same run: one Python ICP call per
  (pattern, rotation) with a KD-tree over the densified pattern and numpy Kabsch.

Numba and BLAS run single-threaded (NUMBA_NUM_THREADS=1, one BLAS thread), so both
sides use one core.

Goals (issue 6): >= 100x real time at 500 particles for one firefighter; >= 1x (real
time) for 10 firefighters at 5 000 particles each. Run:

    .venv/bin/python benchmarks/bench_pf_speed.py [--plan flat_125] [--minutes 5]
    .venv/bin/python benchmarks/bench_pf_speed.py --jump-rule   # trust.jump off / on only
    .venv/bin/python benchmarks/bench_pf_speed.py --field       # the field pipeline's filter
"""
from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("NUMBA_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402
from scipy.spatial import cKDTree  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

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


# ----------------------------------------------------------------------------- the peer
def stonesoup_filter(building, odometry: list, particles: int, seed: int = 0
                     ) -> tuple[float, float, float]:
    """(simulated s, wall s, CPU s) of Stone Soup's particle filter with shapely walls
    over one firefighter's odometry (state per particle: x, y [m], heading offset [rad]
    of the INS frame; the same step noise as ours by default)."""
    import shapely
    from stonesoup.models.measurement.base import MeasurementModel
    from stonesoup.models.transition.base import TransitionModel
    from stonesoup.predictor.particle import ParticlePredictor
    from stonesoup.resampler.particle import ESSResampler
    from stonesoup.types.array import StateVectors
    from stonesoup.types.detection import Detection
    from stonesoup.types.hypothesis import SingleHypothesis
    from stonesoup.types.state import ParticleState
    from stonesoup.updater.particle import ParticleUpdater

    rng = np.random.default_rng(seed)
    walls = shapely.multilinestrings(list(building.floors[0].walls))
    shapely.prepare(walls)

    class OdometryTransition(TransitionModel):
        """Each particle moves by the INS step turned by its heading offset, with 5 %
        length and 2 deg heading noise per step."""

        @property
        def ndim_state(self) -> int:
            return 3

        def function(self, state, noise=False, step=(0.0, 0.0), **kwargs):
            x = np.asarray(state.state_vector, float)
            n = x.shape[1]
            off = x[2] + (rng.normal(0, math.radians(2), n) if noise else 0.0)
            scale = 1.0 + (rng.normal(0, 0.05, n) if noise else 0.0)
            c, s_ = np.cos(off), np.sin(off)
            dx, dy = step
            return StateVectors(np.vstack((x[0] + scale * (c * dx - s_ * dy),
                                           x[1] + scale * (s_ * dx + c * dy), off)))

        def rvs(self, num_samples=1, **kwargs):
            raise NotImplementedError

        def pdf(self, state1, state2, **kwargs):
            raise NotImplementedError

    class Uninformative(MeasurementModel):
        """The odometry step carries no position measurement: equal likelihood."""

        @property
        def ndim_meas(self) -> int:
            return 1

        def function(self, state, noise=False, **kwargs):
            raise NotImplementedError

        def rvs(self, num_samples=1, **kwargs):
            raise NotImplementedError

        def pdf(self, state1, state2, **kwargs):
            raise NotImplementedError

        def logpdf(self, state1, state2, **kwargs):
            return np.zeros(np.shape(state2.state_vector)[1])

    def crosses_wall(predicted) -> np.ndarray:
        before = np.asarray(predicted.parent.state_vector, float)[:2].T
        after = np.asarray(predicted.state_vector, float)[:2].T
        return shapely.intersects(shapely.linestrings(np.stack((before, after), 1)), walls)

    lo, hi = building.floors[0].walls.reshape(-1, 2).min(0), building.floors[0].walls.reshape(-1, 2).max(0)
    start = np.vstack((rng.uniform(lo[0], hi[0], particles), rng.uniform(lo[1], hi[1], particles),
                       rng.uniform(-math.pi, math.pi, particles)))
    t0 = odometry[0].t_start
    from datetime import datetime, timedelta
    epoch = datetime(2020, 1, 1)
    state = ParticleState(StateVectors(start), log_weight=np.full(particles, -math.log(particles)),
                          timestamp=epoch + timedelta(seconds=t0))
    predictor = ParticlePredictor(OdometryTransition())
    model = Uninformative(ndim_state=3, mapping=(0,))
    updater = ParticleUpdater(measurement_model=model, resampler=ESSResampler(),
                              constraint_func=crosses_wall)
    w0, c0 = time.perf_counter(), time.process_time()
    for o in odometry:
        when = epoch + timedelta(seconds=o.t)
        predicted = predictor.predict(state, timestamp=when, step=(o.delta[0], o.delta[1]))
        state = updater.update(SingleHypothesis(predicted, Detection(
            np.zeros((1, 1)), timestamp=when, measurement_model=model)))
    return o.t - t0, time.perf_counter() - w0, time.process_time() - c0


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


def run(building, odometry: list, particles: int, patterns: str | None, trust: dict | None = None,
        params: dict | None = None, constraint_params: dict | None = None
        ) -> tuple[float, float, float, dict]:
    """(simulated s, wall s, CPU s, counts) of our filter over all agents' odometry, with
    wall crossing and the search patterns ``patterns`` (``"ours"``, ``"reference"``, or
    None: walls only); ``trust``: the filter's ``trust`` parameters; ``params`` more of
    the filter's, ``constraint_params`` the constraints' by id (walls, icp)."""
    params = {"particles": particles, "start": {"mode": "unknown"}, "trust": trust or {},
              **(params or {})}
    pf, rec, stats = make_component(ParticleFilterEstimator, params, building=building)
    classes = [(WallCrossingConstraint, "walls")]
    if patterns is not None:
        classes.append((ReferenceIcp if patterns == "reference" else SearchPatternIcpConstraint,
                        "icp"))
    all_stats = [stats]
    for cls, cid in classes:
        c, _, cstats = make_component(cls, (constraint_params or {}).get(cid, {}),
                                      building=building, cid=cid)
        c.start()
        pf.constraints.append(c)
        all_stats.append(cstats)
    msgs = sorted((m for agent in odometry for m in agent), key=lambda m: m.t)
    w0, c0 = time.perf_counter(), time.process_time()
    for m in msgs:
        pf.handle("odo", m)
    wall, cpu = time.perf_counter() - w0, time.process_time() - c0
    sim = max(a[-1].t for a in odometry) - min(a[0].t_start for a in odometry)
    counts = {k: v for st in all_stats for c in st.counts.values() for k, v in c.items()}
    return sim, wall, cpu, counts


def jump_rule_costs(building, minutes: float) -> None:
    """Wall / CPU time of the same search with the jump rule off and on (same run)."""
    one = walks(building, 1, minutes)
    times: dict[str, list] = {"off": [], "on": []}
    for _ in range(3):
        for label, trust in (("off", {}), ("on", {"jump": 1.0, "jump_evidence": 20.0})):
            sim, wall, cpu, _ = run(building, one, 500, "ours", trust)
            times[label].append((wall, cpu))
    print(f"walls + patterns, 500 particles, one firefighter, {sim:.0f} s simulated; best of 3")
    for label, t in times.items():
        wall, cpu = min(w for w, _ in t), min(c for _, c in t)
        print(f"jump rule {label:<3}: wall {wall:.3f} s ({sim / wall:.0f}x real time), "
              f"CPU {cpu:.3f} s")
    ratio = min(c for _, c in times["on"]) / min(c for _, c in times["off"])
    print(f"CPU on / off: {ratio:.2f} (goal: within 2x)")


#: the filter of pipelines/search-pattern-pf-field.yaml (walls that may be wrong, gated pattern
#: resampling; its trust rules before / after the drift state and plan-evidence rule below)
FIELD = {"particles": 1000, "motion": {"position_noise": 0.05, "noise_while_still": False}}
FIELD_CONSTRAINTS = {"walls": {"mode": "downweight", "factor": 0.05},
                     "icp": {"sigma": 0.3, "resample_above_m2": 3.0}}
FIELD_BEFORE = {"jump": 1.0, "jump_evidence": 20.0}
FIELD_AFTER = {**FIELD_BEFORE, "plan_evidence": 0.01, "plan_window": 5.0}


def field_costs(building, minutes: float) -> None:
    """CPU time of the field pipeline's filter before and after the heading-drift state and
    the plan-evidence rule, on the same search from its true start (same run, best of 3),
    and the same after-configuration with ICP against every pattern at every comparison
    (as before the comparison was restricted to the particles' own patterns)."""
    from firenav_plugins.constraints.search_pattern_icp.comparison import PatternComparison
    one = walks(building, 1, minutes)
    sp = extract_search_patterns(building)
    loop = sp.positions(sp.sequence("right_hand"))          # the first walk starts at loop[0]
    start = {"mode": "pose", "position": (*loop[0], 0.0),
             "heading": math.atan2(*(loop[1] - loop[0])[::-1])}
    full_compare = PatternComparison.compare
    configs = {
        "before": (FIELD_BEFORE, {}, False),
        "after": (FIELD_AFTER, {"yaw_rate_sigma": "0.05 deg/s"}, False),
        "after, ICP on every pattern": (FIELD_AFTER, {"yaw_rate_sigma": "0.05 deg/s"}, True),
    }
    times: dict[str, list] = {k: [] for k in configs}
    for _ in range(3):
        for label, (trust, motion, full) in configs.items():
            params = {**FIELD, "start": start, "motion": {**FIELD["motion"], **motion}}
            if full:
                PatternComparison.compare = lambda self, odo, patterns=None: full_compare(self, odo)
            try:
                sim, wall, cpu, _ = run(building, one, 1000, "ours", trust, params,
                                        FIELD_CONSTRAINTS)
            finally:
                PatternComparison.compare = full_compare
            times[label].append((wall, cpu))
    print(f"field filter, 1000 particles, known start, one firefighter, {sim:.0f} s simulated; "
          "best of 3")
    for label, t in times.items():
        wall, cpu = min(w for w, _ in t), min(c for _, c in t)
        print(f"{label:<28}: wall {wall:.3f} s ({sim / wall:.0f}x real time), CPU {cpu:.3f} s")
    ratio = min(c for _, c in times["after"]) / min(c for _, c in times["before"])
    print(f"CPU after / before: {ratio:.2f} (goal: within 2x)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plan", default="flat_125")
    ap.add_argument("--minutes", type=float, default=5.0, help="simulated search per firefighter")
    ap.add_argument("--reference-minutes", type=float, default=2.0,
                    help="simulated minutes for the (slow) search-pattern reference")
    ap.add_argument("--jump-rule", action="store_true",
                    help="only the per-step cost with the look-alike jump rule (trust.jump) "
                         "off and on, 500 particles, one firefighter, alternated 3 times")
    ap.add_argument("--field", action="store_true",
                    help="only the per-step cost of the field pipeline's filter before / after "
                         "this round's drift state and plan-evidence rule, alternated 3 times")
    args = ap.parse_args()
    from threadpoolctl import threadpool_limits
    threadpool_limits(1)
    building = load_building(bundled_plan(args.plan))
    # warm up the compiled kernels so that compilation is not timed
    run(building, walks(building, 1, 0.7), 100, "ours")
    if args.jump_rule:
        jump_rule_costs(building, args.minutes)
        return
    if args.field:
        field_costs(building, args.minutes)
        return
    rows = []
    try:
        import stonesoup  # noqa: F401
    except ImportError:
        stonesoup = None
    for particles in (500, 5000):
        one = walks(building, 1, args.minutes)
        sim, wall, cpu, _ = run(building, one, particles, None)
        rows.append(("ours, walls", particles, 1, sim, wall, cpu, 0))
        if stonesoup is not None:
            sim_s, wall_s, cpu_s = stonesoup_filter(building, one[0], particles)
            rows.append(("Stone Soup + shapely, walls", particles, 1, sim_s, wall_s, cpu_s, 0))
        for n_ff in (1, 10):
            sim, wall, cpu, counts = run(building, walks(building, n_ff, args.minutes),
                                         particles, "ours")
            rows.append(("ours, walls + patterns", particles, n_ff, sim, wall, cpu,
                         counts.get("comparisons", 0)))
        sim_r, wall_r, cpu_r, counts_r = run(building, walks(building, 1, args.reference_minutes),
                                             particles, "reference")
        rows.append(("ours, walls + reference ICP", particles, 1, sim_r, wall_r, cpu_r,
                     counts_r.get("comparisons", 0)))
    print(f"plan {args.plan}; real-time factor = simulated time / wall time (and / CPU "
          f"time); 10 firefighters: all processed together; one thread everywhere"
          + ("" if stonesoup else "; Stone Soup not installed (pip install -e '.[bench]')"))
    print(f"{'impl':<30} {'particles':>9} {'ff':>3} {'sim [s]':>8} {'wall [s]':>9} "
          f"{'CPU [s]':>8} {'comparisons':>11} {'RT (wall)':>10} {'RT (CPU)':>9}")
    for impl, particles, n_ff, sim, wall, cpu, comps in rows:
        print(f"{impl:<30} {particles:>9} {n_ff:>3} {sim:>8.0f} {wall:>9.2f} {cpu:>8.2f} "
              f"{comps:>11} {sim / wall:>9.1f}x {sim / cpu:>8.1f}x")
    for particles in (500, 5000):
        ours = next(r for r in rows if r[:2] == ("ours, walls", particles))
        peer = next((r for r in rows if r[:2] == ("Stone Soup + shapely, walls", particles)), None)
        if peer is not None:
            print(f"walls only, {particles} particles: ours {peer[4] / ours[4]:.1f}x faster "
                  f"than Stone Soup + shapely (wall), {peer[5] / ours[5]:.1f}x (CPU)")
    goal1 = next(r for r in rows if r[:3] == ("ours, walls + patterns", 500, 1))
    goal2 = next(r for r in rows if r[:3] == ("ours, walls + patterns", 5000, 10))
    print(f"goal >= 100x at 500 particles, 1 firefighter: {goal1[3] / goal1[4]:.0f}x "
          f"({'met' if goal1[3] / goal1[4] >= 100 else 'NOT met'})")
    print(f"goal >= 1x at 5000 particles, 10 firefighters: {goal2[3] / goal2[4]:.1f}x "
          f"({'met' if goal2[3] / goal2[4] >= 1 else 'NOT met'})")


if __name__ == "__main__":
    main()
