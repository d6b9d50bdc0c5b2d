"""Thinning long time series for plotting without losing a peak.

A plot a few hundred pixels wide cannot show 60 000 samples; sending them all costs megabytes
per slider move. `thin_minmax` keeps, in each of `max_points / 2` equal buckets of samples, the
samples where any curve is smallest and largest (in time order), plus the first and the last:
every curve's global and per-bucket extrema survive, so no peak a user looks for disappears.
"""

from __future__ import annotations

import itertools

import numpy as np

MAX_POINTS = 2000
"""Points per curve sent to a plot."""


def thin_minmax(t: np.ndarray, curves: np.ndarray, max_points: int = MAX_POINTS) -> np.ndarray:
    """Indices (sorted, unique) of the samples to keep: t (T,), curves (C, T). All samples when
    T ≤ max_points. NaN samples are ignored when looking for extrema."""
    n = len(t)
    if n <= max_points:
        return np.arange(n)
    curves = np.atleast_2d(np.asarray(curves, dtype=float))
    buckets = max(1, (max_points - 2) // (2 * max(1, len(curves))))
    edges = np.linspace(0, n, buckets + 1).astype(int)
    keep = [np.array([0, n - 1])]
    finite = np.where(np.isfinite(curves), curves, np.nan)
    for start, stop in itertools.pairwise(edges):
        if stop <= start:
            continue
        block = finite[:, start:stop]
        valid = ~np.all(np.isnan(block), axis=1)
        if not valid.any():
            continue
        keep.append(start + np.nanargmin(block[valid], axis=1))
        keep.append(start + np.nanargmax(block[valid], axis=1))
    return np.unique(np.concatenate(keep))
