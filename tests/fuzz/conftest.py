"""Fuzz tier: each test's memory held to its own start (the closing lines are tests/conftest.py's)."""

from __future__ import annotations

import pytest

from tests.fuzz.harness import STATS, peak_rss_bytes


@pytest.fixture(autouse=True)
def _rss_from_this_test() -> None:
    """Each fuzz test's cases are held to the process's peak RSS when the test starts: a worker that
    ran a heavy test of another module first has its peak raised by that one, not by a case."""
    STATS.rss_start_bytes = peak_rss_bytes()
