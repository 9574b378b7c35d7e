"""Shared test fixtures."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from hypothesis import settings

#: Every property test draws the same examples on every run (a seeded search, no example
#: database): a red run can be re-run and read, and CI's verdict does not depend on the draw.
#: A test's own ``@settings`` inherits this.
settings.register_profile("cobotsafety", derandomize=True, database=None)
settings.load_profile("cobotsafety")

REPO = Path(__file__).resolve().parents[1]
#: Real sensor data kept beside the checkout (../shared/data): the full leg_tracker bags.
SHARED_DATA = REPO.parent / "shared" / "data"
#: The excerpt of those bags shipped in the repository (tests/data/leg_tracker/README.md).
EXCERPT_DATA = REPO / "tests" / "data"
#: Set to "excerpt" to test with the excerpt even when ../shared/data is there.
DATA_ENV = "COBOTSAFETY_TEST_DATA"


def real_data_folder() -> Path:
    """../shared/data when present (and not overridden by ``COBOTSAFETY_TEST_DATA=excerpt``),
    else the excerpt in tests/data; both hold ``leg_tracker/`` with the same bag names."""
    choice = os.environ.get(DATA_ENV, "")
    if choice not in ("", "excerpt", "shared"):
        raise pytest.UsageError(f"{DATA_ENV} must be 'excerpt' or 'shared', got {choice!r}")
    if choice != "excerpt" and (choice == "shared" or SHARED_DATA.is_dir()):
        return SHARED_DATA
    return EXCERPT_DATA


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """The real, labelled data folder (``real_data_folder``); a missing folder fails the test
    (never skips it)."""
    folder = real_data_folder()
    assert (folder / "leg_tracker").is_dir(), f"real data folder missing: {folder / 'leg_tracker'}"
    return folder


@pytest.fixture(scope="session")
def full_bags(shared_data) -> bool:
    """True with the full bags of ../shared/data, False with the excerpt."""
    return shared_data == SHARED_DATA


@pytest.fixture(scope="module")
def browser():
    """A headless Chromium context (``browser_page.launch``) for one test module."""
    from playwright.sync_api import sync_playwright

    from browser_page import launch

    with sync_playwright() as playwright:
        context = launch(playwright)
        yield context
        context.close()
