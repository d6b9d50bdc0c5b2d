"""The whole-body QP's vectorised assembly (app.core.dynamics.wbc_qp) against a plain one
written here from the equations, one corner and one row block at a time, on random states:
random configurations, velocities, planned accelerations, all four contact states and a CoM
state error. Same A, p, l, u (to round-off), so the fast path solves the same QP."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from app.core.dynamics.lqr import B_COM
from app.core.dynamics.wbc import WbcParams, make_qp
from app.core.dynamics.wbc_terms import SampleInput
from app.core.robot.loading import load_robot
from tests.conftest import ROBAN_URDF


def random_state(robot, rng):
    model = robot.model
    q = pin.randomConfiguration(
        model, -np.ones(model.nq) * 0.5 + pin.neutral(model), np.ones(model.nq) * 0.5
    )
    q[3:7] = rng.normal(size=4)
    q[3:7] /= np.linalg.norm(q[3:7])
    return q, rng.normal(size=model.nv), rng.normal(size=model.nv)


def plain_problem(qp, q, v, qdd_des, contacts, com_error):
    """A, p, l, u of eqs. 12–18 built directly (see wbc_qp's docstring for the layout)."""
    model, data = qp.model, qp.model.createData()
    nv, n, m, r, c, w = qp.nv, qp.n, qp.m, qp.rows, qp.cols, qp.weights
    M = pin.crba(model, data, q).copy()
    h = pin.rnea(model, data, q, v, np.zeros(nv)).copy()
    pin.forwardKinematics(model, data, q, v, np.zeros(nv))
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    W = qp.W
    Phi = np.zeros((nv, 32))
    J_feet, drift = [], []
    for foot, fid in enumerate(qp.foot_ids):
        J_lwa = pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
        R = data.oMf[fid].rotation
        for corner, p_local in enumerate(qp.corners[foot]):
            r_c = R @ p_local
            J_point = J_lwa[:3] - pin.skew(r_c) @ J_lwa[3:]  # velocity of the corner point
            for i in range(4):
                Phi[:, 16 * foot + 4 * corner + i] = J_point.T @ W[:, i]
        J_feet.append(pin.getFrameJacobian(model, data, fid, pin.LOCAL))
        drift.append(pin.getFrameAcceleration(model, data, fid, pin.LOCAL).vector)
    J, drift = np.vstack(J_feet), np.concatenate(drift)
    u, lim = qp.unactuated, qp.actuated[qp.limited]
    A = np.zeros((m, n))
    A[r["dyn"], c["qdd"]] = M[u]
    A[r["dyn"], c["beta"]] = -Phi[u]
    A[r["contact"], c["qdd"]] = J
    A[r["contact"], c["eta"]] = -np.eye(12)
    A[r["tau"], c["qdd"]] = M[lim]
    A[r["tau"], c["beta"]] = -Phi[lim]
    A[r["beta"], c["beta"]] = np.eye(32)
    A[r["eta"], c["eta"]] = np.eye(12)
    lower, upper = np.full(m, -np.inf), np.full(m, np.inf)
    lower[r["dyn"]] = upper[r["dyn"]] = -h[u]
    slip = -drift - w.alpha * J @ v
    for foot in range(2):
        rows = np.arange(r["contact"].start + 6 * foot, r["contact"].start + 6 * foot + 6)
        betas = np.arange(r["beta"].start + 16 * foot, r["beta"].start + 16 * foot + 16)
        if contacts[foot]:
            lower[rows] = upper[rows] = slip[6 * foot : 6 * foot + 6]
        lower[betas], upper[betas] = 0.0, (np.inf if contacts[foot] else 0.0)
    lower[r["tau"]] = -w.tau_max[qp.limited] - h[lim]
    upper[r["tau"]] = w.tau_max[qp.limited] - h[lim]
    lower[r["eta"]], upper[r["eta"]] = -w.eta_max, w.eta_max
    # V: ū = G β + g − c̈_des, c̈_des from pinocchio's CoM acceleration of the plan.
    pin.centerOfMass(model, data, q, v, qdd_des)
    com_acc = data.acom[0]
    G = np.tile(W, 8) / qp.mass
    d = qp.gravity - com_acc
    H_u = (w.r_lqr + w.a**2 * w.q_lqr) * np.eye(3)
    g_u = w.a * w.q_lqr * com_error[:3] + B_COM.T @ w.S @ com_error
    p = np.zeros(n)
    p[c["qdd"]] = -2.0 * w.w_qdd * qdd_des
    p[c["beta"]] = 2.0 * G.T @ (H_u @ d + g_u)
    return A, p, lower, upper


@pytest.mark.parametrize("name", ["servo_biped", "roban"])
def test_vectorised_assembly_equals_the_plain_one(name):
    robot = load_robot(ROBAN_URDF if name == "roban" else "servo_biped")
    qp = make_qp(robot, WbcParams(), "proxqp")  # the full QP, whose A, p, l, u these are
    rng = np.random.default_rng(12)
    for trial in range(12):
        q, v, qdd_des = random_state(robot, rng)
        contacts = np.array([trial % 2 == 0, trial % 4 < 2])
        com_error = rng.normal(size=6) if trial % 3 == 0 else np.zeros(6)
        terms = qp.kinematics(q, v, qdd_des)
        qp.solve(SampleInput(terms, v, qdd_des, contacts, com_error))
        A, p, lower, upper = plain_problem(qp, q, v, qdd_des, contacts, com_error)
        assert qp.last_problem is not None
        p_fast, l_fast, u_fast = qp.last_problem
        scale = max(1.0, np.abs(A).max())
        np.testing.assert_allclose(qp.A, A, atol=1e-10 * scale, rtol=0)
        np.testing.assert_allclose(p_fast, p, atol=1e-9 * max(1.0, np.abs(p).max()), rtol=0)
        for fast, plain in ((l_fast, lower), (u_fast, upper)):
            assert np.array_equal(np.isinf(fast), np.isinf(plain))
            finite = np.isfinite(plain)
            tol = 1e-9 * max(1.0, np.abs(plain[finite]).max())
            np.testing.assert_allclose(fast[finite], plain[finite], atol=tol, rtol=0)
