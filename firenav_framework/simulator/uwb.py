"""UWB two-way ranging from a worn tag to fixed anchors (DW1000 class).

ORCA paper, Sec. 3.1: a Decawave DW1000 pair, one anchor left at the entrance (the
fall-back point), ranging through walls where multipath lengthens the first path.
Model per range:

* line of sight: true 3D distance plus white noise ``sigma_m``;
* through walls: a positive bias (the direct path is attenuated and a longer one is
  detected), ``nlos_bias_m`` per wall on average, varying smoothly as the tag moves,
  plus ``nlos_sigma_m`` extra noise per wall;
* outliers: with ``outlier_prob`` a late multipath peak, 1-10 m too long;
* dropouts: ``dropout_prob`` plus ``dropout_per_wall`` per wall, and none beyond the
  range, which shrinks with walls.

The Range message carries the nominal ``sigma_m`` and ``nlos=False``: the device
does not know; spotting NLOS is the sensor plugin's job.
"""
from __future__ import annotations

import numpy as np

from .radio import ShadowField
from .scenario import UwbConfig


def uwb_ranges(t: np.ndarray, tag_xyz: np.ndarray, tag_floor: np.ndarray,
               anchor_xyz: np.ndarray, anchor_floor: int, cfg: UwbConfig, walls: np.ndarray,
               floor_height: float, rng: np.random.Generator
               ) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    """(kept mask (N,), measured range (N,) [m], truth columns) for one tag-anchor pair.

    ``walls`` (N,) walls between tag and anchor; a different floor counts as walls too
    (a slab is a strong obstruction: 3 walls' worth per floor).
    """
    n = len(t)
    true = np.linalg.norm(tag_xyz - anchor_xyz, axis=1)
    obstructions = walls + 3 * np.abs(tag_floor - anchor_floor)
    wiggle = ShadowField(rng, 0.5, 2.0)(tag_xyz[:, :2])      # smooth +-50 % variation
    bias = obstructions * cfg.nlos_bias_m * np.clip(1.0 + wiggle, 0.2, 2.0)
    sigma = cfg.sigma_m + obstructions * cfg.nlos_sigma_m
    meas = true + bias + rng.normal(0.0, 1.0, n) * sigma
    outlier = rng.uniform(size=n) < cfg.outlier_prob
    meas = np.where(outlier, meas + rng.uniform(1.0, 10.0, n), meas)
    p_drop = np.clip(cfg.dropout_prob + cfg.dropout_per_wall * obstructions, 0, 1)
    reach = cfg.max_range_m / (1.0 + 0.5 * obstructions)
    keep = (rng.uniform(size=n) >= p_drop) & (true <= reach)
    meas = np.maximum(meas, 0.0)
    return keep, meas, {"true_range_m": true, "obstructions": obstructions,
                        "outlier": outlier}
