"""Thinning long time series for plotting without losing a peak.

A plot a few hundred pixels wide cannot show 60 000 samples; sending them all costs megabytes
per slider move. `thin_minmax` keeps, in each of `max_points / 2` equal buckets of samples, the
samples where any curve is smallest and largest (in time order), plus the first and the last:
every curve's global and per-bucket extrema survive, so no peak a user looks for disappears.
"""

from __future__ import annotations

import numpy as np

MAX_POINTS = 2000
"""Points per curve sent to a plot."""


def thin_minmax(t: np.ndarray, curves: np.ndarray, max_points: int = MAX_POINTS) -> np.ndarray:
    """Indices (sorted, unique) of the samples to keep: t (T,), curves (C, T). All samples when
    T ≤ max_points. NaN (and infinite) samples are ignored when looking for extrema."""
    n = len(t)
    if n <= max_points:
        return np.arange(n)
    curves = np.atleast_2d(np.asarray(curves, dtype=float))
    buckets = max(1, (max_points - 2) // (2 * max(1, len(curves))))
    edges = np.linspace(0, n, buckets + 1).astype(int)
    starts, sizes = edges[:-1], np.diff(edges)
    starts, sizes = starts[sizes > 0], sizes[sizes > 0]
    # Every bucket at once, one row each; a short bucket is padded with its own last sample
    # (a repeat never wins: arg-min/max return the first occurrence).
    columns = starts[:, None] + np.minimum(np.arange(sizes.max()), sizes[:, None] - 1)
    block = curves[:, columns]  # (C, buckets, width)
    if np.isfinite(curves).all():  # the usual case: no masking copies of the block
        lowest, highest = block.argmin(axis=2), block.argmax(axis=2)
        valid = np.ones(lowest.shape, dtype=bool)
    else:
        missing = ~np.isfinite(block)  # NaN and ±inf samples are ignored
        valid = ~np.all(missing, axis=2)  # (C, buckets): the curve has a sample in the bucket
        lowest = np.argmin(np.where(missing, np.inf, block), axis=2)
        highest = np.argmax(np.where(missing, -np.inf, block), axis=2)
    bucket = np.nonzero(valid)[1]
    picked = [np.array([0, n - 1]), columns[bucket, lowest[valid]], columns[bucket, highest[valid]]]
    return np.unique(np.concatenate(picked))
