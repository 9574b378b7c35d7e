"""Shared test fixtures."""

from __future__ import annotations

from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
#: Real sensor data kept beside the checkout (../shared/data); CI provides it.
SHARED_DATA = REPO.parent / "shared" / "data"


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """The real, labelled data folder; a missing folder fails the test (never skips it)."""
    assert SHARED_DATA.is_dir(), f"real data folder missing: {SHARED_DATA} (../shared/data)"
    return SHARED_DATA
