"""Per-step cost of the pdr_ekf estimator, now and at a reference revision, in one run.

    .venv/bin/python benchmarks/bench_rfid_step.py                 # against 0b3ad41
    .venv/bin/python benchmarks/bench_rfid_step.py --ref main --repeat 5

The same synthetic input (tests/rfid/synth.py: two firefighters on the three-storey
plan's ground floor, the first deploying a tag at six doors, the second reading them;
strides of 1.3 m every 1.1 s, a 1 s synchronous update) is fed to the estimator of this
checkout and to the one of ``--ref`` (its ``plugins/estimators`` extracted with ``git
archive`` into a temporary package), alternating, ``--repeat`` times each. Printed: the
median wall time per input message (strides, tag events, ticks) of both and the ratio.
Only the ratio means anything (the machine is shared).
"""
from __future__ import annotations

import argparse
import importlib
import math
import subprocess
import sys
import tarfile
import tempfile
import time
from io import BytesIO
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from firenav_framework.building import bundled_plan, load_building  # noqa: E402
from firenav_framework.testing import make_component  # noqa: E402
from tests.rfid.synth import (closest_passes, deployments, detections, feed,  # noqa: E402
                              odometry, walk)
from tests.rfid.test_route import DOORS, ROUTE, TAGS  # noqa: E402

DEG = math.pi / 180


def reference_estimator(rev: str, into: Path):
    """The PdrEkfEstimator class of revision ``rev``, imported from ``into``."""
    blob = subprocess.run(["git", "-C", str(REPO), "archive", rev, "plugins/estimators"],
                          check=True, capture_output=True).stdout
    with tarfile.open(fileobj=BytesIO(blob)) as tar:
        tar.extractall(into, filter="data")
    (into / "plugins").rename(into / "ref_plugins")
    (into / "ref_plugins" / "__init__.py").touch()
    sys.path.insert(0, str(into))
    return importlib.import_module("ref_plugins.estimators.pdr_ekf").PdrEkfEstimator


def messages(building):
    sites = {d: building.door(d).center for d in DOORS}
    w1 = walk(ROUTE * 3, stride=1.3, t0=10.0)
    w2 = walk(ROUTE * 3, stride=1.25, t0=float(w1.t[-1]) + 60.0)
    rng = np.random.default_rng(7)
    odo = (odometry(w1, agent="ff1", rate=0.3 * DEG, scale=1.03, noise=0.03, rng=rng)
           + odometry(w2, agent="ff2", rate=-0.4 * DEG, scale=0.96, noise=0.03, rng=rng))
    p1, p2 = closest_passes(w1, sites), closest_passes(w2, sites)
    return (odo + deployments(p1, TAGS, "ff1") + detections(p1, TAGS, "ff1")
            + detections(p2, TAGS, "ff2"))


def time_once(cls, building, msgs) -> float:
    ekf, _, _ = make_component(cls, {}, building=building)
    ekf.start()
    t0 = time.perf_counter()
    feed(ekf, msgs)
    return time.perf_counter() - t0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ref", default="0b3ad41", help="reference revision (default 0b3ad41)")
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args(argv)
    from firenav_plugins.estimators.pdr_ekf import PdrEkfEstimator
    building = load_building(bundled_plan("three_storey"))
    msgs = messages(building)
    n = len(msgs) + int(max(m.t for m in msgs))          # messages + ~one tick a second
    with tempfile.TemporaryDirectory() as tmp:
        ref = reference_estimator(args.ref, Path(tmp))
        now, before = [], []
        for _ in range(args.repeat):
            before.append(time_once(ref, building, msgs))
            now.append(time_once(PdrEkfEstimator, building, msgs))
    a, b = np.median(before) / n * 1e6, np.median(now) / n * 1e6
    print(f"pdr_ekf per input message ({n} messages, median of {args.repeat}): "
          f"{args.ref} {a:.1f} us, this checkout {b:.1f} us, ratio {b / a:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
