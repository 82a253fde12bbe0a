"""Building tests: the real datasets are required here (a missing one fails the test)."""
from __future__ import annotations

from pathlib import Path

import pytest

from tests.conftest import shared_data_dir


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """``../shared/data``; when it is missing the test fails (it is not skipped)."""
    return shared_data_dir() or pytest.fail("real datasets not found: expected ../shared/data "
                                            "next to the repository (or set FIRENAV_SHARED_DATA)")
