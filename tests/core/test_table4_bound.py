"""Table 4 like for like: a baseline whose peak torque is its bound is said to bind, and the
comparison carries the peak of a baseline solved with the bound lifted (issue 26).

Results are constructed with known peaks (no solve): the rule is the definition itself, a peak
on the bound (to 0.1 %) binds, one below does not.
"""

from __future__ import annotations

import dataclasses

import pytest

from app.core.collocation.result import GaitResult
from app.core.collocation.settings import GaitSettings
from app.core.collocation.table4 import bound_binds, table4_comparison


def _gait(peak_Nm: float, bound_Nm: float = 13.0) -> GaitResult:
    settings = dataclasses.replace(GaitSettings(), tau_max_Nm=bound_Nm)
    return dataclasses.replace(
        GaitResult.refused(settings, "constructed"), converged=True, max_abs_tau_Nm=peak_Nm
    )


def test_a_peak_on_the_bound_binds_and_one_below_does_not():
    assert bound_binds(_gait(13.0))
    assert bound_binds(_gait(12.995))  # the solver's bound, met to round-off
    assert not bound_binds(_gait(11.5))  # the paper's baseline peak under the same 13 N·m
    assert not bound_binds(_gait(float("nan")))  # no gait: nothing binds


def test_the_comparison_reads_the_lifted_baseline_peak():
    symmetric, baseline, lifted = _gait(8.55), _gait(13.0), _gait(15.2, bound_Nm=130.0)
    report = table4_comparison(symmetric, baseline, lifted)
    assert report["bound_binds"] == [False, True]
    assert report["torque_bound_Nm"] == [13.0, 13.0]
    unbounded = report["baseline_bound_lifted"]
    assert unbounded["max_abs_tau_Nm"] == 15.2 and not unbounded["binds"]
    assert unbounded["ratio"] == pytest.approx(8.55 / 15.2)
    assert table4_comparison(symmetric, _gait(11.6))["baseline_bound_lifted"] is None
