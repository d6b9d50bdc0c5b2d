"""The gait NLP's cheaper set-up (issue 28) reaches the optima of the previous one.

- IPOPT is built on an MX function of (x, p) over the SX cost and constraint functions
  (nlp._oracle) instead of the SX expressions themselves: the same values and derivatives,
  built in about half the time.
- The built-in guess solves its ~130 leg IK poses together (LegPosture.solve_many) instead of
  one after another (LegPosture.solve, warm-started from the pose before).

The previous set-up is rebuilt here: nlpsol on the problem's SX expressions with the same
derivative functions and options, started from the guess made pose by pose. Both must reach the
same optimum (objective to 1e-6 relative, states to tolerance) on the paper's case and on
servo_biped.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from app.core.collocation import guess
from app.core.collocation.defaults import robot_gait_defaults
from app.core.collocation.gait_problem import GaitProblem
from app.core.collocation.guess import LegPosture
from app.core.collocation.planar_model import BASE_DOF, PlanarModel, evaluate
from app.core.collocation.settings import GaitSettings
from app.core.collocation.transcription import STANCE, stance_rows
from app.core.robot.loading import load_robot


def _case(name: str) -> tuple[PlanarModel, GaitSettings]:
    planar = PlanarModel(load_robot(name))
    if name == "dircon_biped":
        return planar, GaitSettings()
    return planar, robot_gait_defaults(planar).settings


def _one_by_one(self: LegPosture, bases: np.ndarray, targets: dict) -> np.ndarray:
    """The previous guess's IK: each pose solved alone, warm from the one before."""
    return np.array(
        [
            self.solve(base, {s: tuple(t[i]) for s, t in targets.items()})
            for i, base in enumerate(bases)
        ]
    )


def _previous_setup(problem: GaitProblem, settings: GaitSettings) -> tuple[float, np.ndarray]:
    """(objective, x) of the cold solve as the previous set-up ran it."""
    compiled = problem.compiled
    options = {k: v for k, v in compiled.options.items() if k != "iteration_callback"}
    solver = ca.nlpsol("previous", "ipopt", problem.expressions(), options)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(LegPosture, "solve_many", _one_by_one)
        x0 = problem._new_guess(settings)
    lbx, ubx, lbg, ubg = problem._bounds(settings)
    out = solver(
        x0=np.clip(x0, lbx, ubx), p=problem._parameters(settings),
        lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg,
    )  # fmt: skip
    assert solver.stats()["return_status"] == "Solve_Succeeded"
    return float(out["f"]), np.asarray(out["x"].full()).ravel()


@pytest.fixture(scope="module", params=["dircon_biped", "servo_biped"])
def solved(request):
    planar, settings = _case(request.param)
    problem = GaitProblem(planar, settings.knots, settings.baseline)
    return problem, settings, problem.solve(settings, cold=True)


def test_the_studio_reaches_the_previous_setups_optimum(solved):
    problem, settings, result = solved
    objective, x = _previous_setup(problem, settings)
    assert result.converged
    assert abs(result.objective - objective) <= 1e-6 * abs(objective)
    scale = max(1.0, float(np.abs(x).max()))
    assert np.abs(result.z - x).max() < 1e-4 * scale


def test_the_ik_of_all_poses_at_once_is_the_ik_pose_by_pose(solved):
    model = solved[0].model
    rng = np.random.default_rng(0)
    n = 20
    posture = LegPosture(model)
    height = posture.standing_height
    bases = np.column_stack(
        [rng.uniform(-0.1, 0.1, n) * height, rng.uniform(0.93, 0.99, n) * height, np.zeros(n)]
    )
    targets = {  # within the legs' reach: steps and lifts of a few % of the standing height
        side: np.column_stack(
            [bases[:, 0] + rng.uniform(-0.1, 0.1, n) * height, rng.uniform(0.0, 0.03, n) * height]
        )
        for side in ("left", "right")
    }
    together = LegPosture(model).solve_many(bases, targets)
    alone = np.array(
        [
            LegPosture(model).solve(bases[i], {s: tuple(t[i]) for s, t in targets.items()})
            for i in range(n)
        ]
    )
    np.testing.assert_allclose(together, alone, atol=1e-8)
    for i in range(n):  # and the feet are where they were asked to be (within joint limits)
        p = evaluate(model.contact_positions, together[i])
        for side, t in targets.items():
            reached = stance_rows(side) @ p
            np.testing.assert_allclose(reached, [t[i, 0], t[i, 1], t[i, 1]], atol=1e-9)


def test_the_guess_meets_the_knot_dynamics(solved):
    """M a + h = B u + J_sᵀ λ at every node of the guess (the rows it solves), checked on the
    model's own functions one node at a time."""
    problem, settings, _ = solved
    model, layout = problem.model, problem.layout
    times = layout.node_times(np.array(layout.symmetric_durations(settings.H_s)))
    g = guess.initial_guess(
        model, layout, times, settings.H_s, settings.step_length_m, settings.swing_height_m
    )
    for k in range(layout.n_nodes):
        tau = evaluate(model.rnea, g["q"][k], g["v"][k], g["a"][k])
        Js = stance_rows(STANCE[layout.mode_of(k)]) @ evaluate(model.contact_jacobian, g["q"][k])
        generalised = np.concatenate([np.zeros(BASE_DOF), g["u"][k]]) + Js.T @ g["lam"][k]
        np.testing.assert_allclose(generalised, tau, atol=1e-6 * max(1.0, np.abs(tau).max()))
