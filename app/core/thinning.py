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

LOOP_BUCKETS = 400
"""Up to this many buckets, `thin_minmax` finds the extrema bucket by bucket (measured on
60 000 samples: 12 curves in 83 buckets 4.6 ms against 22 ms gathered; one curve in 999
buckets 0.9 ms gathered against 10 ms)."""


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
    if len(starts) <= LOOP_BUCKETS and np.isfinite(curves).all():
        # A few wide buckets (several curves): each bucket's extrema over a slice of every
        # curve, no gathered copy of the curves (which costs more than the loop's calls).
        lowest = np.empty((len(curves), len(starts)), dtype=int)
        highest = np.empty_like(lowest)
        for b, (start, size) in enumerate(zip(starts, sizes, strict=True)):
            window = curves[:, start : start + size]
            lowest[:, b] = window.argmin(axis=1) + start
            highest[:, b] = window.argmax(axis=1) + start
        return np.unique(np.concatenate([np.array([0, n - 1]), lowest.ravel(), highest.ravel()]))
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


def thin_part(
    t: np.ndarray, curves: np.ndarray, of_curves: int, max_points: int = MAX_POINTS
) -> np.ndarray:
    """`thin_minmax`'s picks for `curves` (C, T), C of a plot's `of_curves` curves: the union
    (`np.union1d`) of the parts' picks is `thin_minmax` of all the curves at once (the same
    buckets, each curve's extrema in them), so the curves that do not change are thinned once."""
    if len(t) <= max_points:
        return np.arange(len(t))
    curves = np.atleast_2d(np.asarray(curves, dtype=float))
    buckets = max(1, (max_points - 2) // (2 * max(1, of_curves)))
    return thin_minmax(t, curves, 2 * len(curves) * buckets + 2)
