"""Tests that read ../shared/data fail, never skip, when it is missing."""
from __future__ import annotations

import pytest

from tests.conftest import require_shared_data


def test_missing_datasets_fail_the_test_with_where_they_were_looked_for(monkeypatch, tmp_path):
    missing = tmp_path / "no-such-data"
    monkeypatch.setenv("FIRENAV_SHARED_DATA", str(missing))
    with pytest.raises(pytest.fail.Exception, match=f"real datasets not found at {missing}"):
        require_shared_data()


def test_present_datasets_are_returned(monkeypatch, tmp_path):
    monkeypatch.setenv("FIRENAV_SHARED_DATA", str(tmp_path))
    assert require_shared_data() == tmp_path
