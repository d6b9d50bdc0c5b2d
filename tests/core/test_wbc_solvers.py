"""ProxQP and OSQP on the identical whole-body QPs: same answers, and ProxQP's own answer
checked against the QP's optimality conditions (KKT), computed here from P, p, A, l, u."""

from __future__ import annotations

import numpy as np
import pytest

from app.core.dynamics.wbc import WbcParams, make_qp
from app.core.dynamics.wbc_terms import SampleInput
from app.core.motions.library import run_motion
from app.core.robot.loading import load_robot


@pytest.fixture(scope="module")
def solved_pairs():
    robot = load_robot("servo_biped")
    trajectory = run_motion(robot, "one_leg_squats", dt=0.01).trajectory
    prox, osqp = make_qp(robot, WbcParams(), "proxqp"), make_qp(robot, WbcParams(), "osqp")
    rows = []
    for k in range(0, trajectory.n_samples, 10):
        q, v, a = trajectory.q[k], trajectory.v[k], trajectory.a[k]
        contacts, x_bar = trajectory.contacts[k], np.zeros(6)
        terms = prox.kinematics(q, v, a)
        sol_p = prox.solve(SampleInput(terms, v, a, contacts, x_bar))
        problem, A, duals, x_p = prox.last_problem, prox.A.copy(), prox.last_duals, prox.last_x
        sol_o = osqp.solve(SampleInput(terms, v, a, contacts, x_bar))
        assert sol_p.ok and sol_o.ok
        rows.append(
            {
                "contacts": contacts.copy(),
                "problem": problem,
                "A": A,
                "duals": duals,
                "x_prox": x_p,
                "x_osqp": osqp.last_x,
                "tau_prox": prox.torques(terms, sol_p),
                "tau_osqp": osqp.torques(terms, sol_o),
            }
        )
    return prox, rows


def test_both_solvers_find_the_same_accelerations_and_cost(solved_pairs):
    qp, rows = solved_pairs
    nv = qp.nv
    for row in rows:
        p = row["problem"][0]
        x_p, x_o = row["x_prox"], row["x_osqp"]
        assert np.abs(x_p[:nv] - x_o[:nv]).max() < 1e-3

        def cost(x, p=p):
            return 0.5 * x @ qp.P @ x + p @ x

        # ProxQP's cost is never worse than OSQP's beyond the tolerance, nor far better.
        assert abs(cost(x_p) - cost(x_o)) <= 1e-5 * max(1.0, abs(cost(x_o)))


def test_torques_agree_where_the_forces_are_unique(solved_pairs):
    """On one foot the contact wrench is fixed by the dynamics; on two, the split between
    the feet is set only by ε‖β‖² (ε = 1e-6), which OSQP's relative tolerance leaves loose."""
    _, rows = solved_pairs
    single = [row for row in rows if row["contacts"].sum() == 1]
    assert len(single) >= 5
    for row in single:
        assert np.abs(row["tau_prox"] - row["tau_osqp"]).max() < 1e-4


def test_proxqp_answer_meets_the_kkt_conditions(solved_pairs):
    qp, rows = solved_pairs
    e = qp.n_eq
    for row in rows:
        p, lower, upper = row["problem"]
        A, x = row["A"], row["x_prox"]
        y, z = row["duals"]
        Ax = A @ x
        scale = max(1.0, np.abs(lower[np.isfinite(lower)]).max())
        # Primal feasibility: equalities and bounds.
        assert np.abs(Ax[:e] - lower[:e]).max() < 1e-5 * scale
        assert np.all(Ax[e:] >= lower[e:] - 1e-5 * scale)
        assert np.all(Ax[e:] <= upper[e:] + 1e-5 * scale)
        # Stationarity: P x + p + A_eqᵀ y + Cᵀ z = 0.
        gradient = qp.P @ x + p + A[:e].T @ y + A[e:].T @ z
        assert np.abs(gradient).max() < 1e-4 * max(1.0, np.abs(p).max())
        # Complementarity: a multiplier only on a bound that is reached.
        gap = 1e-4 * scale
        pushing_up, pushing_down = z > 1e-6, z < -1e-6
        assert np.all(Ax[e:][pushing_up] >= upper[e:][pushing_up] - gap)
        assert np.all(Ax[e:][pushing_down] <= lower[e:][pushing_down] + gap)


def test_unknown_solver_is_named():
    robot = load_robot("servo_biped")
    with pytest.raises(ValueError, match="proxqp"):
        make_qp(robot, WbcParams(), "cvxopt")  # type: ignore[arg-type]
