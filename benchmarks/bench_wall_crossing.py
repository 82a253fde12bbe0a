"""Wall-crossing test speed: the particle filter's inner loop (search-pattern paper Sec. IV-E,
"eliminating any particle whose position estimate crosses a wall").

10 000 moves (particles stepping 0.7 m, the paper's 2 Hz odometry at walking pace, and
a second set of 3 m moves) against a floor of about 500 walls, answered by:

* ours: ``Floor.crosses_wall`` (uniform grid + one numba pass over the moves),
* numpy all-pairs: every move against every wall with array orientation tests,
* shapely: ``STRtree.query(moves, predicate="intersects")`` (GEOS, R-tree).

All three must agree (the script stops if they do not). Run:

    .venv/bin/python benchmarks/bench_wall_crossing.py [--moves 10000] [--repeat 7]
"""
from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
import shapely

from firenav_framework.building.sketch import PlanSketch


def office_grid(nx: int = 12, ny: int = 11, size: float = 4.0):
    """A floor of nx x ny rooms of size x size metres, each with a 0.9 m door to the east
    or north neighbour: 528 wall segments for 12 x 11."""
    sk = PlanSketch("grid")
    f = sk.floor(0.0, 3.0)
    for i in range(nx):
        for j in range(ny):
            f.room(f"r{i}_{j}", (i * size, j * size, (i + 1) * size, (j + 1) * size))
            if i + 1 < nx:
                f.door(f"e{i}_{j}", ((i + 1) * size, j * size + 1.2), 0.9, (1, 0))
            if j + 1 < ny:
                f.door(f"n{i}_{j}", (i * size + 2.8, (j + 1) * size), 0.9, (0, 1))
    return sk.build().floor(0)


def numpy_all_pairs(p0: np.ndarray, p1: np.ndarray, walls: np.ndarray, chunk: int = 1000) -> np.ndarray:
    """Straightforward reference: closed-segment intersection of every move with every wall."""
    out = np.zeros(len(p0), dtype=bool)
    a, b = walls[None, :, 0], walls[None, :, 1]

    def orient(p, q, r):
        return (q[..., 0] - p[..., 0]) * (r[..., 1] - p[..., 1]) - (q[..., 1] - p[..., 1]) * (r[..., 0] - p[..., 0])

    for s in range(0, len(p0), chunk):
        c, d = p0[s:s + chunk, None], p1[s:s + chunk, None]
        o1, o2 = orient(a, b, c), orient(a, b, d)
        o3, o4 = orient(c, d, a), orient(c, d, b)
        proper = (o1 * o2 <= 0) & (o3 * o4 <= 0)
        collinear = (o1 == 0) & (o2 == 0)
        # Collinear moves must overlap the wall's extent (bounding-box test suffices then).
        lo, hi = np.minimum(a, b), np.maximum(a, b)
        mlo, mhi = np.minimum(c, d), np.maximum(c, d)
        overlap = np.all((mlo <= hi) & (mhi >= lo), axis=-1)
        out[s:s + chunk] = np.any(proper & (~collinear | overlap), axis=1)
    return out


def shapely_strtree(p0: np.ndarray, p1: np.ndarray, tree: shapely.STRtree) -> np.ndarray:
    moves = shapely.linestrings(np.stack([p0, p1], axis=1))
    src, _ = tree.query(moves, predicate="intersects")
    out = np.zeros(len(p0), dtype=bool)
    out[src] = True
    return out


def timed(fn, repeat: int) -> tuple[float, np.ndarray]:
    times, result = [], None
    for _ in range(repeat):
        t = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times), result


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--moves", type=int, default=10_000)
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()

    floor = office_grid()
    walls = floor.walls
    t = time.perf_counter()
    floor.crosses_wall(np.zeros((1, 2)), np.ones((1, 2)))     # JIT (cached on disk) + grid build
    t_first = time.perf_counter() - t
    t = time.perf_counter()
    tree = shapely.STRtree(shapely.linestrings(walls))
    t_tree = time.perf_counter() - t
    idx = floor.wall_index
    print(f"floor: {len(walls)} walls, {floor.outline.area:.0f} m^2; grid {idx.shape[0]}x{idx.shape[1]} "
          f"cells of {idx.cell:.2f} m; first call (JIT load + grid) {t_first * 1e3:.0f} ms, "
          f"STRtree build {t_tree * 1e3:.1f} ms")
    rng = np.random.default_rng(args.seed)
    print(f"{'moves':>8} {'step':>6} {'crossing':>9}  {'ours':>14} {'numpy all-pairs':>18} "
          f"{'shapely STRtree':>18}  {'ours vs numpy':>13} {'vs shapely':>10}")
    for step in (0.7, 3.0):
        p0 = floor.sample_free(args.moves, rng)
        ang = rng.uniform(-np.pi, np.pi, args.moves)
        p1 = p0 + step * np.column_stack([np.cos(ang), np.sin(ang)])
        t_ours, ours = timed(lambda: floor.crosses_wall(p0, p1), args.repeat)
        t_np, ref = timed(lambda: numpy_all_pairs(p0, p1, walls), max(1, args.repeat // 3))
        t_sh, shp = timed(lambda: shapely_strtree(p0, p1, tree), args.repeat)
        if not (np.array_equal(ours, ref) and np.array_equal(ours, shp)):
            raise SystemExit(f"answers differ: ours/numpy {np.sum(ours != ref)}, "
                             f"ours/shapely {np.sum(ours != shp)} moves")
        rate = [args.moves / x for x in (t_ours, t_np, t_sh)]
        print(f"{args.moves:8d} {step:5.1f}m {ours.mean():8.1%}  {rate[0]:11.3g}/s {rate[1]:15.3g}/s "
              f"{rate[2]:15.3g}/s  {t_np / t_ours:12.0f}x {t_sh / t_ours:9.1f}x")
    pts = floor.sample_free(args.moves, rng)
    t_near, (d_ours, _, _) = timed(lambda: floor.nearest_wall(pts), args.repeat)
    t_shn, (_, d_sh) = timed(lambda: tree.query_nearest(shapely.points(pts), return_distance=True,
                                                         all_matches=False), args.repeat)
    if not np.allclose(d_ours, d_sh, rtol=0, atol=1e-9):
        raise SystemExit("nearest-wall distances differ from shapely")
    t_first, _ = timed(lambda: floor.first_wall_hit(p0, p1), args.repeat)
    print(f"nearest_wall: ours {args.moves / t_near:.3g} points/s, shapely query_nearest "
          f"{args.moves / t_shn:.3g} points/s ({t_shn / t_near:.1f}x); first_wall_hit (3 m moves): "
          f"ours {args.moves / t_first:.3g} moves/s")
    print("(median of repeated runs; answers identical across methods)")


if __name__ == "__main__":
    main()
