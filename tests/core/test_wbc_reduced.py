"""The reduced whole-body QP (app.core.dynamics.wbc_reduced) against the full one (wbc_qp).

- Its answer meets the FULL QP's optimality conditions, checked here from P, p, A, l, u of the
  full QP alone: feasibility, and multipliers found by a bounded least-squares fit
  (scipy's lsq_linear, sign-constrained by which bounds are reached) that zero the gradient
  of the Lagrangian. This holds for the closed-form samples and the DAQP ones alike.
- It gives the full QP's answers as ProxQP finds them, on the paper motions, to ProxQP's own
  accuracy: ProxQP stops at residuals of 1e-6 (wbc_qp.TOLERANCE). On one foot the forces
  are fixed by the dynamics and the torques agree to 1e-3 N·m; on two feet the split of the
  weight between the feet is set only by ε‖β‖² (ε = 1e-6), so a dual residual of 1e-6 leaves
  each β free by up to 1e-6 / (2ε) = 0.5 N there: compare q̈ (1e-4), the net force and the
  status, not the split.
- The closed form and DAQP (two independent ways to the same minimiser) agree.
- One pinocchio pass gives the terms the five passes of the full QP give.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from scipy.optimize import lsq_linear

from app.core.dynamics.wbc import WbcParams, make_qp, torque_feedforward
from app.core.dynamics.wbc_qp import N_CORNERS, N_EDGES
from app.core.dynamics.wbc_terms import SampleInput
from app.core.motions.library import run_motion
from app.core.robot.loading import load_robot

CASES = [
    ("servo_biped", "one_leg_squats"),
    ("servo_biped", "one_leg_stand"),
    ("roban", "com_shift"),
    ("roban", "one_leg_stand"),
]


@pytest.fixture(scope="module")
def trajectories(robots):
    return {
        (name, motion): run_motion(robots[name], motion, dt=0.02).trajectory
        for name, motion in CASES
    }


def full_x(full, reduced_qp, terms, v, contacts, qdd, beta):
    """The full QP's unknowns [q̈, β, η, f] of a reduced answer: η = J q̈ + J̇q̇ + αJq̇ of a foot
    down (eq. 14), 0 in the air (its only term is ‖η‖²)."""
    x = np.zeros(full.n)
    x[full.cols["qdd"]] = qdd
    x[full.cols["beta"]] = beta
    eta = np.zeros(12)
    for foot in range(2):
        if contacts[foot]:
            rows = slice(6 * foot, 6 * foot + 6)
            J = terms.J_feet[rows]
            eta[rows] = J @ qdd + terms.drift_feet[rows] + full.weights.alpha * (J @ v)
    x[full.cols["eta"]] = eta
    return x


def kkt_residual(P, p, A, lower, upper, n_eq, x):
    """(worst bound violation, worst gradient of the Lagrangian) of x for the full QP, with
    multipliers fitted here: free on equalities, ≥ 0 at a reached upper bound, ≤ 0 at a
    reached lower bound, 0 on a bound not reached."""
    Ax = A @ x
    bounds = np.concatenate([lower, upper])
    scale = max(1.0, np.abs(bounds[np.isfinite(bounds)]).max())
    violation = max(
        float(np.max(lower - Ax, initial=0.0)),
        float(np.max(Ax - upper, initial=0.0)),
    )
    reach = 1e-9 * scale
    low = np.full(len(Ax), -np.inf)
    high = np.full(len(Ax), np.inf)
    at_upper = Ax >= upper - reach
    at_lower = Ax <= lower + reach
    inequality = np.arange(len(Ax)) >= n_eq
    low[inequality & at_upper & ~at_lower] = 0.0
    high[inequality & at_lower & ~at_upper] = 0.0
    active = ~inequality | at_upper | at_lower
    gradient = P @ x + p
    if not active.any():
        return violation / scale, float(np.abs(gradient).max())
    fit = lsq_linear(A[active].T, -gradient, bounds=(low[active], high[active]), tol=1e-14)
    return violation / scale, float(np.abs(A[active].T @ fit.x + gradient).max())


@pytest.mark.parametrize("name, motion", CASES)
def test_reduced_answer_meets_the_full_qps_kkt_conditions(robots, trajectories, name, motion):
    robot, traj = robots[name], trajectories[(name, motion)]
    reduced = make_qp(robot, WbcParams(), "reduced")
    full = make_qp(robot, WbcParams(), "proxqp")
    assert reduced.reduced is not None
    paths = set()
    for k in range(0, traj.n_samples, 3):
        q, v, a, contacts = traj.q[k], traj.v[k], traj.a[k], traj.contacts[k]
        terms = reduced.kinematics(q, v, a)
        solution = reduced.solve(SampleInput(terms, v, a, contacts, np.zeros(6)))
        assert solution.ok
        paths.add("daqp" if reduced.last_reduced is not None else "closed form")
        full.solve(SampleInput(full.kinematics(q, v, a), v, a, contacts, np.zeros(6)))
        p, lower, upper = full.last_problem
        x = full_x(full, reduced, terms, v, contacts, solution.qdd, solution.beta)
        violation, gradient = kkt_residual(full.P, p, full.A, lower, upper, full.n_eq, x)
        assert violation < 1e-9, k
        # exact to round-off, against gradients of order 2w|q̈_des| + |p_β| ~ 1e2…1e3
        assert gradient < 1e-9 * max(1.0, np.abs(p).max()), (k, gradient)
    if motion == "one_leg_squats":
        assert paths == {"closed form", "daqp"}  # both paths are exercised


@pytest.mark.parametrize("name, motion", CASES)
def test_reduced_answers_equal_proxqps_on_the_paper_motions(robots, trajectories, name, motion):
    robot, traj = robots[name], trajectories[(name, motion)]
    new = torque_feedforward(robot, traj, solver="reduced")
    old = torque_feedforward(robot, traj, solver="proxqp")
    assert new.status == old.status
    np.testing.assert_allclose(new.qdd, old.qdd, atol=1e-4, rtol=0)
    weight = robot.mass_kg * 9.81
    np.testing.assert_allclose(
        new.contact_forces_N.sum(axis=(1, 2)),
        old.contact_forces_N.sum(axis=(1, 2)),
        atol=1e-5 * weight,
        rtol=0,
    )
    single = traj.contacts.sum(axis=1) == 1
    if single.any():
        np.testing.assert_allclose(new.tau_Nm[single], old.tau_Nm[single], atol=1e-3, rtol=0)
        np.testing.assert_allclose(
            new.contact_forces_N[single], old.contact_forces_N[single], atol=1e-5 * weight, rtol=0
        )
    air = ~traj.contacts
    assert np.all(new.contact_forces_N[air[:, 0], 0] == 0.0)
    assert np.all(new.contact_forces_N[air[:, 1], 1] == 0.0)


def test_closed_form_and_daqp_agree(robots, trajectories):
    robot, traj = robots["servo_biped"], trajectories[("servo_biped", "one_leg_squats")]
    qp = make_qp(robot, WbcParams(), "reduced")
    assert qp.reduced is not None
    closed_samples = daqp_samples = 0
    for k in range(0, traj.n_samples, 2):
        q, v, a, contacts = traj.q[k], traj.v[k], traj.a[k], traj.contacts[k]
        terms = qp.kinematics(q, v, a)
        sample = SampleInput(terms, v, a, contacts, np.zeros(6))
        closed = qp.reduced.unconstrained(sample)
        problem = qp.reduced.problem(sample)
        answer = qp.reduced.solve(problem)
        assert answer.ok
        nb = len(problem.beta_columns)
        bounds = np.concatenate([answer.y[:nb], problem.A @ answer.y])
        reached = (bounds <= problem.lower + 1e-9) | (bounds >= problem.upper - 1e-9)
        if closed is None:  # then some bound is reached at the minimiser
            daqp_samples += 1
            assert reached.any()
        else:
            closed_samples += 1
            np.testing.assert_allclose(closed.qdd, answer.qdd, atol=1e-7, rtol=0)
            # the split between the feet rests on ε = 1e-6 against weights of ~1e2: the
            # reduced Hessian's condition number ~1e8 times round-off, relative to |β|
            beta_scale = max(1.0, np.abs(answer.beta).max())
            np.testing.assert_allclose(closed.beta, answer.beta, atol=1e-5 * beta_scale, rtol=0)
    assert closed_samples > 0 and daqp_samples > 0


@pytest.mark.parametrize("name", ["servo_biped", "roban"])
def test_one_pinocchio_pass_gives_the_five_pass_terms(robots, name):
    robot = robots[name]
    one, five = make_qp(robot, WbcParams(), "reduced"), make_qp(robot, WbcParams(), "proxqp")
    model = robot.model
    rng = np.random.default_rng(7)
    for _ in range(5):
        q = pin.randomConfiguration(model, pin.neutral(model) - 0.5, pin.neutral(model) + 0.5)
        q[3:7] = rng.normal(size=4)
        q[3:7] /= np.linalg.norm(q[3:7])
        v, a = rng.normal(size=model.nv), rng.normal(size=model.nv)
        fast, slow = one.kinematics(q, v, a), five.kinematics(q, v, a)
        for field in ("M", "h", "Phi", "J_feet", "drift_feet", "com_acc"):
            x, y = getattr(fast, field), getattr(slow, field)
            np.testing.assert_allclose(x, y, atol=1e-9 * max(1.0, np.abs(y).max()), err_msg=field)


def test_robots_with_loops_keep_the_full_qp():
    robot = load_robot("hybrid_leg_biped")
    assert robot.tree.loops
    assert make_qp(robot, WbcParams(), "reduced").reduced is None


def test_corner_count_matches_the_reduced_layout():
    from app.core.dynamics import wbc_reduced

    assert wbc_reduced.PER_FOOT == N_CORNERS * N_EDGES


@pytest.mark.parametrize(
    "name, motion", [("servo_biped", "one_leg_squats"), ("roban", "com_shift")]
)
def test_batched_chunk_equals_sample_by_sample(robots, trajectories, name, motion):
    """The feed-forward's batched closed form (all samples of a contact state at once) gives
    the per-sample `solve` answers, to round-off times the conditioning above."""
    robot, traj = robots[name], trajectories[(name, motion)]
    ff = torque_feedforward(robot, traj)
    qp = make_qp(robot, WbcParams(), "reduced")
    for k in range(0, traj.n_samples, 2):
        q, v, a, contacts = traj.q[k], traj.v[k], traj.a[k], traj.contacts[k]
        terms = qp.kinematics(q, v, a)
        solution = qp.solve(SampleInput(terms, v, a, contacts, np.zeros(6)))
        np.testing.assert_allclose(ff.qdd[k], solution.qdd, atol=1e-8, rtol=0)
        tau = qp.torques(terms, solution)
        np.testing.assert_allclose(ff.tau_Nm[k], tau, atol=1e-6 * max(1.0, np.abs(tau).max()))


@pytest.mark.parametrize(
    "name, motion", [("servo_biped", "one_leg_squats"), ("roban", "com_shift")]
)
def test_batched_kinematics_equal_the_five_pass_terms(robots, trajectories, name, motion):
    robot, traj = robots[name], trajectories[(name, motion)]
    one, five = make_qp(robot, WbcParams(), "reduced"), make_qp(robot, WbcParams(), "proxqp")
    picks = np.arange(0, traj.n_samples, 7)
    batch, seconds = one.kinematics_batch(traj.q[picks], traj.v[picks], traj.a[picks])
    assert seconds.shape == picks.shape and np.all(seconds > 0.0)
    for i, k in enumerate(picks):
        fast, slow = one.terms_at(batch, i), five.kinematics(traj.q[k], traj.v[k], traj.a[k])
        for field in ("M", "h", "Phi", "J_feet", "drift_feet", "com_acc"):
            x, y = getattr(fast, field), getattr(slow, field)
            np.testing.assert_allclose(x, y, atol=1e-9 * max(1.0, np.abs(y).max()), err_msg=field)
