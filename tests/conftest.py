"""Shared fixtures."""
from __future__ import annotations

import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]


def shared_data_dir() -> Path | None:
    """``../shared/data`` next to the repository (or $FIRENAV_SHARED_DATA), if present."""
    env = os.environ.get("FIRENAV_SHARED_DATA")
    path = Path(env) if env else REPO.parent / "shared" / "data"
    return path if path.is_dir() else None


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """Path to the real datasets; skips the test where they are absent."""
    path = shared_data_dir()
    if path is None:
        pytest.skip("real datasets not found: expected ../shared/data next to the "
                    "repository (or set FIRENAV_SHARED_DATA)")
    return path


@pytest.fixture(scope="session")
def repo() -> Path:
    return REPO
