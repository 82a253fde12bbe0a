"""Initial particle clouds: known pose, unknown pose, or near an entrance.

All three place particles in the building frame and give each a *walking heading*
[rad]; the filter turns that into the frame rotation of each particle once it knows
the INS heading (:meth:`ParticleStep.frame_yaw_for`).

* known pose (§V-C, "prior information on the initial navigation state"): Gaussian
  around a given position and heading;
* unknown pose (§V-C, "the particles were initialized at random over the navigation
  area"): uniform over the free space of every floor (weighted by floor area) with
  uniform headings;
* near an entrance: uniform within a radius of the entrance, inside the free space,
  heading into the building with a spread.
"""
from __future__ import annotations

import numpy as np

__all__ = ["around_pose", "uniform_free_space", "near_point"]


def around_pose(n: int, xy: np.ndarray, heading: float | None, floor: int, sigma_m: float,
                sigma_heading: float, rng: np.random.Generator
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(xy (n, 2), heading (n,), floor (n,)) Gaussian around a known pose.

    ``heading`` None (unknown) gives uniform headings.
    """
    xy = np.asarray(xy, dtype=float)[:2] + rng.standard_normal((n, 2)) * sigma_m
    if heading is None:
        return xy, rng.uniform(-np.pi, np.pi, n), np.full(n, floor)
    return xy, heading + rng.standard_normal(n) * sigma_heading, np.full(n, floor)


def uniform_free_space(n: int, building, rng: np.random.Generator
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Uniform over the free space of all floors, all headings."""
    areas = np.array([f.free_space.area for f in building.floors])
    if not np.any(areas > 0):
        raise ValueError(f"building {building.name!r} has no free space to spread particles over")
    counts = rng.multinomial(n, areas / areas.sum())
    xy = np.concatenate([building.floors[i].sample_free(int(c), rng)
                         for i, c in enumerate(counts) if c])
    floor = np.repeat(np.arange(len(areas)), counts)
    return xy, rng.uniform(-np.pi, np.pi, n), floor


def near_point(n: int, floor_obj, xy: np.ndarray, radius_m: float, heading: float,
               sigma_heading: float, rng: np.random.Generator
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Uniform in the free space within ``radius_m`` of ``xy`` on one floor."""
    import shapely

    disc = shapely.Point(*np.asarray(xy, float)[:2]).buffer(radius_m)
    region = floor_obj.free_space.intersection(disc)
    if region.is_empty or region.area <= 0:
        raise ValueError(f"no free space within {radius_m} m of {tuple(np.round(xy, 2))} "
                         f"on floor {floor_obj.index}")
    x0, y0, x1, y1 = region.bounds
    out = np.empty((0, 2))
    while len(out) < n:
        m = 2 * (n - len(out)) + 16
        cand = np.column_stack([rng.uniform(x0, x1, m), rng.uniform(y0, y1, m)])
        out = np.vstack([out, cand[shapely.contains_xy(region, cand[:, 0], cand[:, 1])]])
    return out[:n], heading + rng.standard_normal(n) * sigma_heading, np.full(n, floor_obj.index)
