"""Shared fixtures."""
from __future__ import annotations

import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]


def shared_data_dir() -> Path:
    """``../shared/data`` next to the repository, or ``$FIRENAV_SHARED_DATA`` when set."""
    env = os.environ.get("FIRENAV_SHARED_DATA")
    return Path(env) if env else REPO.parent / "shared" / "data"


def require_shared_data() -> Path:
    """The real datasets' folder; FAILS the calling test where it is absent (CI always
    has it, so a missing folder is a broken checkout, never a reason to pass)."""
    path = shared_data_dir()
    if not path.is_dir():
        pytest.fail(f"real datasets not found at {path}: the tests that read them cannot "
                    f"run. Put the datasets at ../shared/data next to the repository or "
                    f"set FIRENAV_SHARED_DATA to their folder.", pytrace=False)
    return path


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """Path to the real datasets (see :func:`require_shared_data`)."""
    return require_shared_data()


@pytest.fixture(scope="session")
def repo() -> Path:
    return REPO
