"""A two-process LocalCluster on loopback, shared by this folder's tests (starting one
costs a few seconds)."""
from __future__ import annotations

import pytest


@pytest.fixture(scope="package")
def cluster():
    from firenav_framework.scaleout import DaskExecutor
    with DaskExecutor(workers=2) as executor:
        yield executor
