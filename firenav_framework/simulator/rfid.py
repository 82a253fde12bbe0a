"""RFID reads of door tags by a reader worn on the body (RFID paper, "RFID tags").

Tags sit at the top centre of door jambs and at both ends of stairs. The reader tries
``rate_hz`` times a second; a try reads a tag with a probability that falls from 0.95
inside ``range_m`` to zero over about half a metre beyond it (a logistic edge). Reads
of one tag within ``window_s`` are reported as one detection with their count and
mean signal strength.
"""
from __future__ import annotations

import numpy as np

from .scenario import RfidConfig


def rfid_detections(t: np.ndarray, reader_xyz: np.ndarray,
                    tags: list[tuple[str, np.ndarray, float]], cfg: RfidConfig,
                    rng: np.random.Generator) -> list[tuple[float, str, int, float]]:
    """Detections (t, tag id, reads, rssi dBm) for read attempts at ``t`` (N,).

    ``tags``: (tag id, position (3,), time it was attached).
    """
    out: list[tuple[float, str, int, float]] = []
    if not tags or not len(t):
        return out
    window = np.floor(t / cfg.window_s).astype(np.int64)
    for tag_id, pos, t_on in tags:
        d = np.linalg.norm(reader_xyz - pos, axis=1)
        p = 0.95 / (1.0 + np.exp((d - cfg.range_m) / 0.12))
        ok = (t >= t_on) & (rng.uniform(size=len(t)) < p)
        if not ok.any():
            continue
        rssi = -45.0 - 20.0 * np.log10(np.maximum(d, 0.1)) + rng.normal(0, 2.0, len(t))
        w = np.unique(window[ok])
        idx = np.flatnonzero(ok)
        counts = np.bincount(np.searchsorted(w, window[ok]), minlength=len(w))
        sums = np.bincount(np.searchsorted(w, window[ok]), weights=rssi[ok], minlength=len(w))
        last = np.zeros(len(w), int)
        np.maximum.at(last, np.searchsorted(w, window[ok]), idx)
        for j in range(len(w)):
            out.append((float(t[last[j]]), tag_id, int(counts[j]),
                        round(float(sums[j] / counts[j]), 1)))
    out.sort(key=lambda r: r[0])
    return out
