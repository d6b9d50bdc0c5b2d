"""The Pareto front against a brute-force O(n²) dominance check on random data."""

from __future__ import annotations

import numpy as np
import pytest

from app.core.sweeps.pareto import pareto_mask


def brute_force(values: np.ndarray, senses: list[str]) -> np.ndarray:
    """Row i is on the front iff it is finite and no finite row j dominates it."""
    n = len(values)
    better = [(lambda a, b: a < b) if s == "min" else (lambda a, b: a > b) for s in senses]
    at_least = [(lambda a, b: a <= b) if s == "min" else (lambda a, b: a >= b) for s in senses]
    finite = [bool(np.isfinite(values[i]).all()) for i in range(n)]
    out = np.zeros(n, dtype=bool)
    for i in range(n):
        if not finite[i]:
            continue
        dominated = False
        for j in range(n):
            if j == i or not finite[j]:
                continue
            cols = range(values.shape[1])
            if all(at_least[c](values[j, c], values[i, c]) for c in cols) and any(
                better[c](values[j, c], values[i, c]) for c in cols
            ):
                dominated = True
                break
        out[i] = not dominated
    return out


@pytest.mark.parametrize("seed", range(12))
@pytest.mark.parametrize("senses", [["min", "min"], ["min", "max"], ["max", "max"]])
def test_front_equals_brute_force_on_random_data(seed, senses):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 120))
    if seed % 3 == 0:  # ties: small integers
        values = rng.integers(0, 6, size=(n, 2)).astype(float)
    else:
        values = rng.normal(size=(n, 2))
    if seed % 4 == 1:  # points without a gait
        values[rng.random(n) < 0.2, int(rng.integers(0, 2))] = np.nan
    np.testing.assert_array_equal(pareto_mask(values, senses), brute_force(values, senses))


def test_three_metrics_and_degenerate_inputs():
    rng = np.random.default_rng(99)
    values = rng.integers(0, 4, size=(80, 3)).astype(float)
    senses = ["min", "max", "min"]
    np.testing.assert_array_equal(pareto_mask(values, senses), brute_force(values, senses))
    assert pareto_mask(np.zeros((0, 2)), ["min", "min"]).shape == (0,)
    assert not pareto_mask(np.full((3, 2), np.nan), ["min", "min"]).any()
    with pytest.raises(ValueError):
        pareto_mask(values, ["min", "up", "min"])
