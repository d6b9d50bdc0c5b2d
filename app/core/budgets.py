"""Budgets of time and memory that every run is checked against before it starts.

A motion is an array of samples × configuration values, and every sample costs one IK or QP
solve (about a millisecond). A run over these budgets is refused up front, with the number
asked for and the limit, instead of allocating gigabytes or running for hours:

    MAX_SAMPLES = 100 000            samples in one motion (1 000 s at 100 Hz, ~2 min of IK)
    MAX_SAMPLE_VALUES = 20 000 000   samples × configuration values (160 MB per float64 array)
    MIN_DT_S = 1e-4 s, MAX_DT_S = 1 s   sample time step
"""

from __future__ import annotations

import math

from app.core.errors import StudioError

MAX_SAMPLES = 100_000
MAX_SAMPLE_VALUES = 20_000_000
MIN_DT_S = 1e-4
MAX_DT_S = 1.0


class BudgetExceeded(StudioError):
    """A run that would exceed a memory or time budget; refused before it starts."""


def check_dt(dt: float, what: str = "dt") -> float:
    """dt [s] if finite and within [MIN_DT_S, MAX_DT_S]; BudgetExceeded otherwise."""
    if not (isinstance(dt, int | float) and math.isfinite(dt) and MIN_DT_S <= dt <= MAX_DT_S):
        raise BudgetExceeded(
            f"{what} = {dt:g} s; give a time step in [{MIN_DT_S:g}, {MAX_DT_S:g}] s"
        )
    return float(dt)


def check_samples(n_samples: int | float, n_values: int, what: str) -> int:
    """n_samples if within MAX_SAMPLES and n_samples × n_values within MAX_SAMPLE_VALUES."""
    if not n_samples <= MAX_SAMPLES:
        raise BudgetExceeded(
            f"{what}: {n_samples:.6g} samples; at most {MAX_SAMPLES} are computed (raise the "
            "time step, shorten or speed up the motion)"
        )
    if n_samples * n_values > MAX_SAMPLE_VALUES:
        raise BudgetExceeded(
            f"{what}: {n_samples:.6g} samples × {n_values} values; at most "
            f"{MAX_SAMPLE_VALUES} values are held"
        )
    return int(n_samples)
