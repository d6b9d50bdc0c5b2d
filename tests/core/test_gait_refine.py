"""Mesh refinement (GaitProblem.solve above REFINE_ABOVE_KNOTS): a first solve of a fine mesh
starts from the coarse optimum interpolated onto it (app.core.collocation.mesh_interpolation),
ends at the direct (cold) fine solve's optimum in fewer iterations, and meets the fine NLP's
constraints, evaluated here from its own symbolic expressions and bounds."""

from __future__ import annotations

import dataclasses

import casadi as ca
import numpy as np
import pytest

from app.core.collocation import gait_problem
from app.core.collocation.gait_problem import COARSE_KNOTS, GaitProblem
from app.core.collocation.mesh_interpolation import interpolate_point
from app.core.collocation.settings import GaitSettings

FINE_KNOTS = 64


@pytest.fixture(scope="module")
def solved():
    """The refined first solve (REFINE_ABOVE_KNOTS lowered to this test's mesh, to keep it
    affordable), the same refinement made by hand, and the direct cold solve."""
    settings = GaitSettings(knots=FINE_KNOTS)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(gait_problem, "REFINE_ABOVE_KNOTS", FINE_KNOTS - 1)
        fine = GaitProblem(knots=FINE_KNOTS)
        refined = fine.solve(settings)
    coarse = GaitProblem(knots=COARSE_KNOTS)
    coarse_result = coarse.solve(dataclasses.replace(settings, knots=COARSE_KNOTS))
    by_hand = GaitProblem(knots=FINE_KNOTS).solve(
        settings, start_z=interpolate_point(coarse, coarse_result.z, fine)
    )
    direct = GaitProblem(knots=FINE_KNOTS).solve(settings, cold=True)
    return fine, settings, refined, coarse_result, by_hand, direct


def test_refined_gait_equals_the_direct_fine_solve(solved):
    _, _, refined, coarse, _, direct = solved
    assert coarse.converged and refined.converged and direct.converged
    scale = max(1.0, float(np.abs(direct.z).max()))
    assert np.abs(refined.z - direct.z).max() < 1e-4 * scale
    assert abs(refined.objective - direct.objective) <= 1e-6 * max(1.0, abs(direct.objective))
    # The warm start is the point of it: fewer iterations than the cold fine solve.
    assert refined.iterations < direct.iterations


def test_refined_gait_meets_the_fine_constraints(solved):
    fine, settings, refined, *_ = solved
    problem = fine.expressions()
    g = ca.Function("g", [problem["x"], problem["p"]], [problem["g"]])
    lbx, ubx, lbg, ubg = fine._bounds(settings)
    values = np.asarray(g(refined.z, fine._parameters(settings))).ravel()
    tol = 1e-6
    assert np.all(values >= lbg - tol) and np.all(values <= ubg + tol)
    assert np.all(refined.z >= lbx - tol) and np.all(refined.z <= ubx + tol)


def test_interpolation_keeps_a_point_of_the_same_mesh(solved):
    """Onto the same mesh, interpolation returns the point itself (a round trip)."""
    fine, _, refined, *_ = solved
    np.testing.assert_allclose(interpolate_point(fine, refined.z, fine), refined.z, atol=1e-12)


def test_a_first_solve_of_a_fine_mesh_refines_by_itself(solved):
    """The first solve's start is the coarse optimum interpolated: the same answer, in as many
    iterations, as the fine solve started by hand from that interpolation."""
    _, _, refined, _, by_hand, _ = solved
    np.testing.assert_allclose(refined.z, by_hand.z, rtol=0, atol=1e-8)
    assert refined.iterations == by_hand.iterations


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
