"""The Pareto front of a set of points: those no other point beats in every metric.

Point a dominates b when a is at least as good in every metric and strictly better in one
("good" is smaller for "min", larger for "max"). The front is found by sorting: after a
lexicographic sort (best first), a point can only be dominated by one before it, and, if it is,
by one already on the front, so each point is compared with the front so far only
(O(n · front) instead of O(n²)).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np


def pareto_mask(values: np.ndarray, senses: Sequence[str]) -> np.ndarray:
    """Which rows of `values` (shape (n, m)) are on the Pareto front, as a bool array (n,).

    `senses[j]` is "min" or "max" for column j. Rows with a NaN (no gait) are never on the
    front and dominate nothing. Equal rows do not dominate each other: all are kept."""
    values = np.asarray(values, dtype=float)
    if values.ndim != 2 or values.shape[1] != len(senses):
        raise ValueError(f"values of shape {values.shape} for {len(senses)} senses")
    signs = np.array([1.0 if s == "min" else -1.0 for s in senses])
    if any(s not in ("min", "max") for s in senses):
        raise ValueError(f"senses must be 'min' or 'max', not {list(senses)}")
    cost = values * signs  # every column minimised
    mask = np.zeros(len(cost), dtype=bool)
    finite = np.flatnonzero(np.isfinite(cost).all(axis=1))
    order = finite[np.lexsort(cost[finite].T[::-1])]
    front: list[np.ndarray] = []
    for i in order:
        c = cost[i]
        if any(bool(np.all(f <= c) and np.any(f < c)) for f in front):
            continue
        front.append(c)
        mask[i] = True
    return mask
