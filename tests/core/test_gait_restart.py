"""A re-solve after a slider change: it converges (the K0 6.5 → 2 case of issue 23), a warm
start that stalls restarts cold, and a solve that finds no gait names the constraint groups
that are really violated at its last point.

The K0 = 2 gait is checked with pinocchio on the full 3-D robot (equations of motion at the
knots, stance points on the floor), not with the planner's own functions; the infeasible case
is checked by measuring the swing soles' heights with pinocchio.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pinocchio as pin
import pytest

import app.core.collocation.gait_problem as gait_problem
from app.core.collocation.defaults import default_settings
from app.core.collocation.dircon import GaitProblem, PlanarModel
from app.core.robot.loading import load_robot
from app.studio.gait_text import Solve, status_line
from tests.sole_frames import model_with_sole_edge_frames

EOM_TOL = 1e-4
"""[N, N·m]: the collocation constraints hold to IPOPT's 1e-6 at the knots."""
STANCE_TOL_M = 1e-5


@pytest.fixture(scope="module")
def servo():
    robot = load_robot("servo_biped")
    planar = PlanarModel(robot)
    return robot, planar, GaitProblem(planar, knots=38)


def eom_residual(full, planar, result, k):
    """Gᵀ (RNEA(q, v, a) − Σ Jᵀ f) − B u at node k, with pinocchio on the full robot."""
    model, data, frame_ids = full
    q = planar.to_full_q(result.q[k])
    v = planar.to_full_v(result.q[k], result.v[k])
    a = planar.to_full_a(result.q[k], result.v[k], result.a[k])
    tau = pin.rnea(model, data, q, v, a).copy()
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    for i, fid in enumerate(frame_ids):
        J = pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)[:3]
        fx, fz = result.contact_forces_N[k, i]
        tau -= J.T @ np.array([fx, 0.0, fz])
    residual = planar.velocity_map(result.q[k]).T @ tau
    residual[3:] -= result.u[k]
    return residual


def sole_heights(full, planar, result):
    """(nodes, 4) heights [m] of left heel, left toe, right heel, right toe, by pinocchio."""
    model, data, frame_ids = full
    heights = []
    for qk in result.q:
        pin.framesForwardKinematics(model, data, planar.to_full_q(qk))
        heights.append([data.oMf[f].translation[2] for f in frame_ids])
    return np.array(heights)


def test_k0_2_after_a_k0_6_5_solve_converges_and_is_a_gait(servo):
    """Issue 23 defect 2: on servo_biped, the default solve then K0 = 2 warm-started from it.
    Before the fix this stalled for 1000 iterations (so did a cold solve); now it converges
    directly from the warm start, and its gait meets the equations of motion and contacts."""
    robot, planar, problem = servo
    reported = dataclasses.replace(  # servo_biped's defaults when the defect was reported
        default_settings(planar), step_length_m=0.0617, H_s=0.537
    )
    first = problem.solve(reported)
    assert first.converged, first.status
    changed = dataclasses.replace(first.settings, K0=2.0)
    result = problem.solve(changed, warm_start=first)
    assert result.converged, f"{result.status}: {result.blame}"
    assert not result.restarted_cold  # the root cause is fixed: the warm start converges
    assert result.iterations < gait_problem.WARM_ITERATIONS_BEFORE_FALLBACK
    cold = problem.solve(changed, cold=True)
    assert cold.converged and result.objective == pytest.approx(cold.objective, rel=1e-4)

    full = model_with_sole_edge_frames(robot)
    worst = max(np.abs(eom_residual(full, planar, result, k)).max() for k in range(len(result.t)))
    assert worst < EOM_TOL
    heights = sole_heights(full, planar, result)
    stance = {0: (0, 1), 1: (2, 3), 2: (0, 1)}  # left, right, left stance
    for k, mode in enumerate(result.mode):
        assert np.abs(heights[k, list(stance[int(mode)])]).max() < STANCE_TOL_M
    assert heights.min() > -STANCE_TOL_M  # no sole point below the floor at any node
    assert result.bound_check is not None and result.bound_check.holds


def test_a_warm_start_that_stalls_restarts_cold(small, monkeypatch):
    """A warm start that has not converged within its budget is abandoned for a cold start
    from the built-in guess: the solve ends at the cold solve's optimum, its iterations are
    those of both attempts, the result says it restarted, and the iteration callback sees one
    increasing count."""
    problem, first = small
    changed = dataclasses.replace(first.settings, K0=5.0)
    cold = problem.solve(changed, cold=True)
    problem.solve(first.settings)
    monkeypatch.setattr(gait_problem, "WARM_ITERATIONS_BEFORE_FALLBACK", 2)
    seen: list[int] = []
    warm = problem.solve(
        changed, warm_start=first, iteration_callback=lambda i, f, v: seen.append(i)
    )
    assert warm.converged and cold.converged
    assert warm.restarted_cold and warm.warm_iterations_before_cold == 2
    assert warm.iterations == 2 + cold.iterations
    assert warm.objective == pytest.approx(cold.objective, rel=1e-6)
    assert seen == list(range(len(seen))) and len(seen) == warm.iterations + 2
    line = status_line(Solve("gait-1", changed, ended_s=warm.solve_s, result=warm), _no())
    assert "restarted cold" in line and "did not converge in 2 iterations" in line
    problem.solve(first.settings)


def _no():
    from app.studio.gait_text import GaitResults

    return GaitResults()


def test_an_unreachable_clearance_is_blamed_on_the_clearance(small, full, planar):
    """A mid-swing clearance of 1 m on a robot whose pelvis is at most ~1 m high cannot be
    met. The blame names the swing clearance first, with the violation that pinocchio
    measures: the highest swing sole at any node stays far below 1 m."""
    problem, first = small
    impossible = dataclasses.replace(first.settings, swing_height_m=1.0, swing_clearance_m=1.0)
    result = problem.solve(impossible)
    assert not result.converged
    assert result.blame.startswith("Violated at its last point, worst first: the swing clearance")
    heights = sole_heights(full, planar, result)
    shortfall = 1.0 - heights.max()
    assert shortfall > 0.2  # measured independently: no sole point comes near 1 m
    named = float(result.blame.split(" by ", 1)[1].split()[0])
    assert named >= shortfall - 1e-6  # the clearance's reported violation is at least that
    assert problem.last_good is not None and problem.last_good.converged
