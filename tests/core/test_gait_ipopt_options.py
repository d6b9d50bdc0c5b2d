"""IPOPT's options of round 3 (issue 28) keep the gait planner's optima.

The studio sets MUMPS's pivot tolerance to 1e-10 (at most 1e-6) and IPOPT's first barrier
parameter to 0.5 on the symmetric gait (app/core/collocation/gait_problem.py, IPOPT_OPTIONS;
the baseline keeps 0.1: tests/core/test_gait_blocks.py solves it). The same problem is
built here with IPOPT's own values for these three options (pivot tolerance 1e-6, at most 0.1;
first barrier parameter 0.1): from the same guess, both reach the same optimum (objective to
1e-6 relative, states to tolerance) on the paper's case and on servo_biped, the studio's in
fewer iterations; a warm re-solve after one slider reaches the same optimum under both.
"""

from __future__ import annotations

import dataclasses

import pytest

from app.core.collocation import gait_problem
from app.core.collocation.gait_problem import GaitProblem
from tests.core.test_gait_speed import gait_case, same_optimum

ROUND_3 = ("ipopt.mumps_pivtol", "ipopt.mumps_pivtolmax", "ipopt.mu_init")


@pytest.fixture(scope="module", params=["dircon_biped", "servo_biped"])
def pair(request):
    """(settings, the studio's problem, the same problem under IPOPT's values)."""
    planar, settings = gait_case(request.param)
    assert all(key in gait_problem.IPOPT_OPTIONS for key in ROUND_3)
    studio = GaitProblem(planar, settings.knots, settings.baseline)
    with pytest.MonkeyPatch.context() as patch:
        for key in ROUND_3:
            patch.delitem(gait_problem.IPOPT_OPTIONS, key)
        ipopt_values = GaitProblem(planar, settings.knots, settings.baseline)
    return settings, studio, ipopt_values


def test_cold_solves_reach_the_same_optimum_in_fewer_iterations(pair):
    settings, studio, ipopt_values = pair
    ours, theirs = studio.solve(settings, cold=True), ipopt_values.solve(settings, cold=True)
    same_optimum(ours, theirs, z_within=1e-3)
    assert ours.iterations < theirs.iterations


def test_warm_resolves_reach_the_same_optimum(pair):
    settings, studio, ipopt_values = pair
    anchor = ipopt_values.solve(settings, cold=True)
    changed = dataclasses.replace(settings, K0=0.8 * settings.K0)
    ours = studio.solve(changed, warm_start=anchor)
    theirs = ipopt_values.solve(changed, warm_start=anchor)
    assert ours.warm_iterations_before_cold == theirs.warm_iterations_before_cold == 0
    same_optimum(ours, theirs, z_within=1e-3)
