"""The default-step bisection (StepSearch) against a brute-force scan of a known threshold: a
walk starts below `limit` and not above it. The search must stop within SEARCH_SOLVES tries,
return a step that starts, and be no further below the threshold than the bisection's
resolution (default / 2**SEARCH_SOLVES, plus the 1 mm rounding)."""

from __future__ import annotations

import numpy as np
import pytest

from app.core.walking.start_fit import SEARCH_SOLVES, StepSearch


@pytest.mark.parametrize("limit", [0.02, 0.137, 0.15, 0.2, 0.3])
def test_the_search_finds_the_longest_step_that_starts_within_its_resolution(limit):
    default = 0.3386
    search = StepSearch(default, default / 0.6)
    while (step := search.next_step()) is not None:
        search.record(step, step <= limit)
    assert search.tried <= SEARCH_SOLVES
    grid = np.arange(0.001, default, 0.001)
    longest = grid[grid <= limit].max()  # brute force over 1 mm steps
    assert search.found and search.lo <= limit
    assert longest - search.lo <= default / 2**SEARCH_SOLVES + 0.001
    note = search.note()
    assert note.startswith(f"default steps shortened from 16.9 to {50 * search.lo:.1f} cm")


def test_no_step_that_starts_keeps_the_default_and_says_so():
    search = StepSearch(0.3386, 0.56)
    while (step := search.next_step()) is not None:
        search.record(step, False)
    assert not search.found and search.tried == SEARCH_SOLVES
    assert "kept" in search.note()
