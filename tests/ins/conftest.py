"""Fixtures of the INS tests: parameters, engines and a few real recordings."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from firenav_plugins.estimators.zupt_ins import BlockResult, InsEngine, ZuptInsParams

#: device (z-down) -> FLU axes of the real datasets' MicroStrain
FLU = np.array([1.0, -1.0, -1.0])
REPO = Path(__file__).resolve().parents[2]


def run_engine(t, acc, gyro, params: ZuptInsParams | None = None, rate: float = 200.0,
               blocks: list[int] | None = None) -> BlockResult:
    """Whole recording through a fresh engine (optionally cut at the given indices)."""
    params = params or ZuptInsParams()
    eng = InsEngine(params.detector_config(rate), params.filter_config(rate))
    cuts = [0, *(blocks or []), len(t)]
    parts = [eng.process(t[a:b], acc[a:b], gyro[a:b]) for a, b in zip(cuts[:-1], cuts[1:])]
    parts.append(eng.finish())
    return BlockResult.concat(parts)


def vicon_trial(shared_data: Path, name: str):
    """A PyShoe VICON trial of ../shared/data by its name (arrays, device frame)."""
    from firenav_framework.sources.readers.foot_imu_datasets import load_vicon_trial
    return load_vicon_trial(shared_data / "pyshoe-vicon" / f"{name}.mat")


def _trial_fixture(name: str, doc: str):
    """A session fixture of the VICON trial ``name``."""
    def fixture(shared_data: Path):
        return vicon_trial(shared_data, name)
    fixture.__doc__ = doc
    return pytest.fixture(scope="session")(fixture)


vicon_walk = _trial_fixture("2017-11-22-11-22-03", "A normal-walking PyShoe VICON trial.")
vicon_run = _trial_fixture("2017-11-27-11-12-44", "A running PyShoe VICON trial (stance "
                           "statistic 100x higher than walking).")
vicon_crawl = _trial_fixture("2018-02-22-10-09-36", "A crawling PyShoe VICON trial (hands "
                             "and knees: the boot rests upside down).")
vicon_crawl_tuning = _trial_fixture("2018-02-22-10-10-29", "A crawling VICON trial of the "
                                    "tuning half (even index in name order).")
