"""Mesh refinement (app.core.collocation.refine): the coarse optimum interpolated onto a finer
mesh starts a fine solve that ends at the direct fine solve's optimum, and meets the fine
NLP's constraints, evaluated here from its own symbolic expressions and bounds."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from app.core.collocation import gait_problem
from app.core.collocation.gait_problem import GaitProblem
from app.core.collocation.mesh_interpolation import interpolate_point
from app.core.collocation.refine import solve_refined
from app.core.collocation.settings import GaitSettings

FINE_KNOTS = 64


@pytest.fixture(scope="module")
def solved():
    coarse, fine = GaitProblem(knots=38), GaitProblem(knots=FINE_KNOTS)
    settings = GaitSettings(knots=FINE_KNOTS)
    refined = solve_refined(coarse, fine, settings)
    direct = GaitProblem(knots=FINE_KNOTS).solve(settings, cold=True)
    return coarse, fine, settings, refined, direct


def test_refined_gait_equals_the_direct_fine_solve(solved):
    _, _, _, refined, direct = solved
    assert refined.coarse.converged and refined.fine.converged and direct.converged
    scale = max(1.0, float(np.abs(direct.z).max()))
    assert np.abs(refined.fine.z - direct.z).max() < 1e-4 * scale
    assert abs(refined.fine.objective - direct.objective) <= 1e-6 * max(1.0, abs(direct.objective))
    # The warm start is the point of it: fewer iterations than the cold fine solve.
    assert refined.fine.iterations < direct.iterations


def test_refined_gait_meets_the_fine_constraints(solved):
    _, fine, settings, refined, _ = solved
    problem = fine.compiled.problem
    g = ca.Function("g", [problem["x"], problem["p"]], [problem["g"]])
    lbx, ubx, lbg, ubg = fine._bounds(settings)
    values = np.asarray(g(refined.fine.z, fine._parameters(settings))).ravel()
    tol = 1e-6
    assert np.all(values >= lbg - tol) and np.all(values <= ubg + tol)
    assert np.all(refined.fine.z >= lbx - tol) and np.all(refined.fine.z <= ubx + tol)


def test_interpolation_keeps_a_point_of_the_same_mesh(solved):
    """Onto the same mesh, interpolation returns the point itself (a round trip)."""
    coarse, _, _, refined, _ = solved
    z = refined.coarse.z
    np.testing.assert_allclose(interpolate_point(coarse, z, coarse), z, rtol=0, atol=1e-12)


def test_a_first_solve_of_a_fine_mesh_refines_by_itself(solved, monkeypatch):
    """Above REFINE_ABOVE_KNOTS (lowered here to this test's mesh, to keep it affordable) a
    solve without a warm start starts from the coarse optimum: the same answer as the explicit
    refinement, in as many iterations."""
    _, _, settings, refined, _ = solved
    monkeypatch.setattr(gait_problem, "REFINE_ABOVE_KNOTS", FINE_KNOTS - 1)
    auto = GaitProblem(knots=FINE_KNOTS).solve(settings)
    assert auto.converged
    np.testing.assert_allclose(auto.z, refined.fine.z, rtol=0, atol=1e-8)
    assert auto.iterations == refined.fine.iterations


def test_a_callback_that_stops_the_coarse_stage_stops_the_whole_solve():
    """A first solve above REFINE_ABOVE_KNOTS reports the coarse solve's iterations to the
    callback too; stopping there ends the solve (no fine solve from the guess afterwards)."""
    knots = gait_problem.COARSE_KNOTS + 2
    seen: list[int] = []

    def stop_at_three(iteration: int, _objective: float, _violation: float) -> bool:
        seen.append(iteration)
        return iteration >= 3

    result = GaitProblem(knots=knots).solve(
        GaitSettings(knots=knots), iteration_callback=stop_at_three
    )
    assert not result.converged and "stopped" in result.status
    assert seen == [0, 1, 2, 3]  # the coarse solve's, and nothing after the stop
