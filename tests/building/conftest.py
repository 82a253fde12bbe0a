"""Building tests: the real datasets are required here (a missing one fails the test)."""
from __future__ import annotations

from pathlib import Path

import pytest

from tests.conftest import shared_data_dir


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """Path to ``../shared/data``; fails (does not skip) when it is missing."""
    path = shared_data_dir()
    if path is None:
        pytest.fail("real datasets not found: expected ../shared/data next to the repository "
                    "(or set FIRENAV_SHARED_DATA)")
    return path
