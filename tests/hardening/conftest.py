"""Shared inputs of the hardening tests: one short simulated team recording."""
from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from firenav_framework.simulator import load_scenario, simulate
from firenav_framework.simulator.output import write_simulation


@pytest.fixture(scope="session")
def sim_folder(tmp_path_factory) -> Path:
    """``firenav simulate demo`` for 30 s (two firefighters): streams.jsonl, IMU CSVs, truth."""
    out = tmp_path_factory.mktemp("sim") / "demo"
    write_simulation(simulate(load_scenario("demo"), 0, duration_s=30.0), out)
    return out


@pytest.fixture
def sim_copy(sim_folder, tmp_path) -> Path:
    """A private copy of :func:`sim_folder` that a test may damage."""
    dest = tmp_path / "sim"
    shutil.copytree(sim_folder, dest)
    return dest
