"""The plots' time cursor: the curves keep their samples and stay on the same lines, and the
cursor column rises above its [0, 1] scale at the cursor time only."""

from __future__ import annotations

import numpy as np
import pytest

from app.core.time_cursor import CURSOR_HIGH, CURSOR_LOW, with_time_cursor


@pytest.mark.parametrize("time_s", [0.0, 0.013, 0.5, 1.37, 2.0])
def test_the_curves_keep_their_samples_and_lines(time_s):
    rng = np.random.default_rng(3)
    t = np.sort(rng.uniform(0.0, 2.0, 200))
    t[0], t[-1] = 0.0, 2.0
    slope, offset = rng.normal(size=(2, 4, 1))
    rows = slope * t + offset  # straight lines: the inserted samples must lie on them
    data = with_time_cursor(t, rows, time_s)
    assert len(data.x) == len(t) + 3 and np.all(np.diff(data.x) >= 0.0)
    inserted = np.flatnonzero(data.x == time_s)
    assert len(inserted) >= 3
    np.testing.assert_allclose(data.rows, slope * data.x + offset, atol=1e-12)
    # Removing three samples at the cursor time gives back the original curves exactly.
    keep = np.ones(len(data.x), bool)
    keep[np.flatnonzero(data.cursor == CURSOR_HIGH)[0] + np.array([-1, 0, 1])] = False
    np.testing.assert_array_equal(data.x[keep], t)
    np.testing.assert_array_equal(data.rows[:, keep], rows)


def test_the_cursor_column_is_a_vertical_line_at_the_time():
    t = np.linspace(0.0, 1.0, 11)
    data = with_time_cursor(t, np.vstack([t, -t]), 0.42)
    high = np.flatnonzero(data.cursor > 1.0)
    assert len(high) == 1 and data.x[high[0]] == 0.42
    # Its neighbours are at the same time and below the scale: the line goes up and down there.
    assert data.x[high[0] - 1] == data.x[high[0] + 1] == 0.42
    assert np.all(np.delete(data.cursor, high) < 0.0) and data.time_s == 0.42


def test_a_time_outside_the_axis_is_clamped_and_none_draws_no_cursor():
    t = np.linspace(1.0, 3.0, 5)
    rows = np.ones((1, 5))
    assert with_time_cursor(t, rows, 9.0).time_s == 3.0
    assert with_time_cursor(t, rows, -1.0).time_s == 1.0
    hidden = with_time_cursor(t, rows, None)
    assert hidden.time_s is None and np.all(hidden.cursor == CURSOR_LOW)
    np.testing.assert_array_equal(hidden.x, t)
    with pytest.raises(ValueError, match="samples"):
        with_time_cursor(t, np.ones((1, 4)), 2.0)
