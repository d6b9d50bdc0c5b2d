"""A vertical line at the playback time in a plot whose curves share one time axis.

uPlot's aligned mode gives every curve the same x values, so a vertical line cannot be a curve
of its own with two points. `with_time_cursor` inserts the cursor time three times into the time
axis (the curves are interpolated there, so they stay continuous) and returns a cursor column
meant for a scale fixed to [0, 1]: it is below that range everywhere (clipped away) except at
the middle inserted sample, where it is above it. The curve thus goes straight up and down at
the cursor time only: a vertical line across the whole plot, whatever the curves' units.
"""

from __future__ import annotations

import dataclasses

import numpy as np

CURSOR_LOW = -1.0
"""The cursor column away from the cursor: below its scale's [0, 1] range."""
CURSOR_HIGH = 2.0
"""The cursor column at the cursor: above its scale's [0, 1] range."""


@dataclasses.dataclass(frozen=True, eq=False)
class CursorData:
    x: np.ndarray
    """Time axis [s], shape (T + 3,) with a cursor, (T,) without; non-decreasing."""
    rows: np.ndarray
    """The curves on that axis, shape (C, len(x))."""
    cursor: np.ndarray
    """The cursor column, shape (len(x),): CURSOR_LOW, and CURSOR_HIGH at the cursor."""
    time_s: float | None
    """Where the cursor stands [s] (clamped to the time axis), None without a cursor."""


def with_time_cursor(t: np.ndarray, rows: np.ndarray, time_s: float | None) -> CursorData:
    """Curves `rows` (C, T) over times `t` (T,), with a cursor at `time_s` (None: no cursor,
    the column then stays below its range)."""
    t = np.asarray(t, dtype=float)
    rows = np.atleast_2d(np.asarray(rows, dtype=float))
    if rows.shape[1] != len(t):
        raise ValueError(f"curves of {rows.shape[1]} samples over {len(t)} times")
    if time_s is None or len(t) == 0 or not np.isfinite(time_s):
        return CursorData(t, rows, np.full(len(t), CURSOR_LOW), None)
    at = float(np.clip(time_s, t[0], t[-1]))
    i = int(np.searchsorted(t, at, side="right"))
    values = np.array([np.interp(at, t, row) for row in rows])[:, None]
    x = np.concatenate([t[:i], np.full(3, at), t[i:]])
    out = np.concatenate([rows[:, :i], np.repeat(values, 3, axis=1), rows[:, i:]], axis=1)
    cursor = np.full(len(x), CURSOR_LOW)
    cursor[i + 1] = CURSOR_HIGH
    return CursorData(x, out, cursor, at)
